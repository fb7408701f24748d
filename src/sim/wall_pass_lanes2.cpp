// The wall batch evaluated 2 contacts at a time: SSE2 (baseline). A file of its own, apart from the
// pair batch's, so that the contact laws are inlined into each evaluator as when it was alone.
#include "sim/pair_pass_lanes.hpp"

namespace biodem::sim {

using Lanes2 = stdx::simd<double, stdx::simd_abi::deduce_t<double, 2>>;
static_assert(Lanes2::size() == 2);

template <bool Cohesion, bool Rolling>
void evaluate_wall_batch_lanes2(WallBatch& b) {
  evaluate_wall_batch<Lanes2, Cohesion, Rolling>(b);
}
template void evaluate_wall_batch_lanes2<false, false>(WallBatch&);
template void evaluate_wall_batch_lanes2<false, true>(WallBatch&);
template void evaluate_wall_batch_lanes2<true, false>(WallBatch&);
template void evaluate_wall_batch_lanes2<true, true>(WallBatch&);

}  // namespace biodem::sim
