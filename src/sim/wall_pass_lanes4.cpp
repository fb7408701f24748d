// The wall batch evaluated 4 contacts at a time: AVX2 (built with -mavx2, no FMA: see
// CMakeLists.txt); called only when the CPU has AVX2. A file of its own, apart from the pair
// batch's, so that the contact laws are inlined into each evaluator as when it was alone.
#include "sim/pair_pass_lanes.hpp"

namespace biodem::sim {

using Lanes4 = stdx::simd<double, stdx::simd_abi::deduce_t<double, 4>>;
static_assert(Lanes4::size() == 4);

template <bool Cohesion, bool Rolling>
void evaluate_wall_batch_lanes4(WallBatch& b) {
  evaluate_wall_batch<Lanes4, Cohesion, Rolling>(b);
}
template void evaluate_wall_batch_lanes4<false, false>(WallBatch&);
template void evaluate_wall_batch_lanes4<false, true>(WallBatch&);
template void evaluate_wall_batch_lanes4<true, false>(WallBatch&);
template void evaluate_wall_batch_lanes4<true, true>(WallBatch&);

}  // namespace biodem::sim
