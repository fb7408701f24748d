// The pair batch evaluated 2 contacts at a time: the baseline instruction set (SSE2 on x86-64); built like every other file.
#include "sim/pair_pass_lanes.hpp"

namespace biodem::sim {

using Lanes2 = stdx::simd<double, stdx::simd_abi::deduce_t<double, 2>>;
static_assert(Lanes2::size() == 2);

template <bool Cohesion, bool Rolling>
void evaluate_batch_lanes2(PairBatch& b) {
  evaluate_batch<Lanes2, Cohesion, Rolling>(b);
}
template void evaluate_batch_lanes2<false, false>(PairBatch&);
template void evaluate_batch_lanes2<false, true>(PairBatch&);
template void evaluate_batch_lanes2<true, false>(PairBatch&);
template void evaluate_batch_lanes2<true, true>(PairBatch&);

}  // namespace biodem::sim
