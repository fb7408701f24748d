// The pair batch evaluated 4 contacts at a time: AVX2 (built with -mavx2, no FMA: see CMakeLists.txt); called only when the CPU has AVX2.
#include "sim/pair_pass_lanes.hpp"

namespace biodem::sim {

using Lanes4 = stdx::simd<double, stdx::simd_abi::deduce_t<double, 4>>;
static_assert(Lanes4::size() == 4);

template <bool Cohesion, bool Rolling>
void evaluate_batch_lanes4(PairBatch& b) {
  evaluate_batch<Lanes4, Cohesion, Rolling>(b);
}
template void evaluate_batch_lanes4<false, false>(PairBatch&);
template void evaluate_batch_lanes4<false, true>(PairBatch&);
template void evaluate_batch_lanes4<true, false>(PairBatch&);
template void evaluate_batch_lanes4<true, true>(PairBatch&);

}  // namespace biodem::sim
