// Single-sphere bodies advanced 8 at a time: AVX-512F (built for it, no FMA: see CMakeLists.txt);
// called only when the CPU has it (the pair kernel's choice).
#define BIODEM_BODY_LANES_IMPL 1
#include "sim/body_lanes.hpp"

namespace biodem::sim {

using Lanes8 = stdx::simd<double, stdx::simd_abi::deduce_t<double, 8>>;
static_assert(Lanes8::size() == 8);

template <bool KickFirst>
int advance_sphere_bodies_lanes8(const SphereBodyArrays& a, std::size_t b) {
  return advance_sphere_bodies<Lanes8, KickFirst>(a, b);
}
template int advance_sphere_bodies_lanes8<false>(const SphereBodyArrays&, std::size_t);
template int advance_sphere_bodies_lanes8<true>(const SphereBodyArrays&, std::size_t);

}  // namespace biodem::sim
