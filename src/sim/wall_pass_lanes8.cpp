// The wall batch evaluated 8 contacts at a time: AVX-512F (built with -mavx512f, no FMA: see
// CMakeLists.txt); called only when the CPU has AVX-512F. A file of its own, apart from the pair
// batch's, so that the contact laws are inlined into each evaluator as when it was alone.
#include "sim/pair_pass_lanes.hpp"

namespace biodem::sim {

using Lanes8 = stdx::simd<double, stdx::simd_abi::deduce_t<double, 8>>;
static_assert(Lanes8::size() == 8);

template <bool Cohesion, bool Rolling>
void evaluate_wall_batch_lanes8(WallBatch& b) {
  evaluate_wall_batch<Lanes8, Cohesion, Rolling>(b);
}
template void evaluate_wall_batch_lanes8<false, false>(WallBatch&);
template void evaluate_wall_batch_lanes8<false, true>(WallBatch&);
template void evaluate_wall_batch_lanes8<true, false>(WallBatch&);
template void evaluate_wall_batch_lanes8<true, true>(WallBatch&);

}  // namespace biodem::sim
