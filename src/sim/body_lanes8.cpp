// Single-sphere bodies and clumps advanced 8 at a time: AVX-512F (built for it, no FMA: see CMakeLists.txt);
// called only when the CPU has it (the pair kernel's choice).
#define BIODEM_BODY_LANES_IMPL 1
#include "sim/body_lanes.hpp"

namespace biodem::sim {

using Lanes8 = stdx::simd<double, stdx::simd_abi::deduce_t<double, 8>>;
static_assert(Lanes8::size() == 8);

template <bool KickFirst>
int advance_sphere_bodies_lanes8(const BodyLaneArrays& a, std::size_t b) {
  return advance_sphere_bodies<Lanes8, KickFirst>(a, b);
}
template int advance_sphere_bodies_lanes8<false>(const BodyLaneArrays&, std::size_t);
template int advance_sphere_bodies_lanes8<true>(const BodyLaneArrays&, std::size_t);

template <bool KickFirst>
int advance_clump_bodies_lanes8(const BodyLaneArrays& a, std::size_t b, std::uint32_t n) {
  return advance_clump_bodies<Lanes8, KickFirst>(a, b, n);
}
template int advance_clump_bodies_lanes8<false>(const BodyLaneArrays&, std::size_t, std::uint32_t);
template int advance_clump_bodies_lanes8<true>(const BodyLaneArrays&, std::size_t, std::uint32_t);

}  // namespace biodem::sim
