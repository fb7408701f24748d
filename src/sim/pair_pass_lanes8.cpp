// The pair batch evaluated 8 contacts at a time: AVX-512F (built with -mavx512f, no FMA: see CMakeLists.txt); called only when the CPU has AVX-512F.
#include "sim/pair_pass_lanes.hpp"

namespace biodem::sim {

using Lanes8 = stdx::simd<double, stdx::simd_abi::deduce_t<double, 8>>;
static_assert(Lanes8::size() == 8);

template <bool Cohesion, bool Rolling>
void evaluate_batch_lanes8(PairBatch& b) {
  evaluate_batch<Lanes8, Cohesion, Rolling>(b);
}
template void evaluate_batch_lanes8<false, false>(PairBatch&);
template void evaluate_batch_lanes8<false, true>(PairBatch&);
template void evaluate_batch_lanes8<true, false>(PairBatch&);
template void evaluate_batch_lanes8<true, true>(PairBatch&);

}  // namespace biodem::sim
