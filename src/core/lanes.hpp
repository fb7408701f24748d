// "Lanes": the number type of the shared force laws (src/contact). The laws are templates over a
// real type R. With R = double they are the scalar laws the GPU kernels, the wall contacts and
// the tests use, with Vec3 as their vector; with R = a SIMD vector of doubles (core/lanes_simd.hpp,
// CPU only) the same source evaluates several contacts at once, one per lane, and Vec3T<R> holds
// three such vectors (structure of arrays).
//
// Where the laws branch (the Coulomb and rolling caps) the scalar code keeps its branch and the
// lane code computes both sides and blends them (lane_select); |F_n| is lane_abs. Every
// lane does exactly the scalar law's IEEE operations in the same order (+, -, *, /, sqrt are
// correctly rounded in both), so a lane result equals the scalar result bit for bit as long as
// neither is compiled with fused multiply-add contraction (tests/unit/test_contact_lanes.cpp).
#pragma once
#include <cmath>
#include <type_traits>

#include "core/hd.hpp"
#include "core/vec3.hpp"

namespace biodem {

/// Three components of lane type R (R not double; for double the vector is Vec3).
template <class R>
struct Vec3T {
  R x{}, y{}, z{};
};

template <class R> struct Vec3Of { using type = Vec3T<R>; };
template <> struct Vec3Of<double> { using type = Vec3; };
/// The vector type that goes with real type R: Vec3 for double, Vec3T<R> otherwise.
template <class R> using vec3_t = typename Vec3Of<R>::type;

template <class R> using lane_scalar_t = std::type_identity_t<R>;  // a non-deduced R argument

template <class R> inline Vec3T<R>& operator+=(Vec3T<R>& a, const Vec3T<R>& b) { a.x += b.x; a.y += b.y; a.z += b.z; return a; }
template <class R> inline Vec3T<R>& operator-=(Vec3T<R>& a, const Vec3T<R>& b) { a.x -= b.x; a.y -= b.y; a.z -= b.z; return a; }
template <class R> inline Vec3T<R>& operator*=(Vec3T<R>& a, const lane_scalar_t<R>& s) { a.x *= s; a.y *= s; a.z *= s; return a; }
template <class R> inline Vec3T<R> operator+(Vec3T<R> a, const Vec3T<R>& b) { return a += b; }
template <class R> inline Vec3T<R> operator-(Vec3T<R> a, const Vec3T<R>& b) { return a -= b; }
template <class R> inline Vec3T<R> operator-(const Vec3T<R>& a) { return {-a.x, -a.y, -a.z}; }
template <class R> inline Vec3T<R> operator*(Vec3T<R> a, const lane_scalar_t<R>& s) { return a *= s; }
template <class R> inline Vec3T<R> operator*(const lane_scalar_t<R>& s, Vec3T<R> a) { return a *= s; }
template <class R> inline Vec3T<R> operator/(const Vec3T<R>& a, const lane_scalar_t<R>& s) { return {a.x / s, a.y / s, a.z / s}; }
template <class R> inline R dot(const Vec3T<R>& a, const Vec3T<R>& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
template <class R> inline Vec3T<R> cross(const Vec3T<R>& a, const Vec3T<R>& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
template <class R> inline R norm2(const Vec3T<R>& a) { return dot(a, a); }

/// Lane operations of a SIMD type R: specialised in core/lanes_simd.hpp (abs, select).
template <class R> struct LaneOps;

/// |x| as the scalar laws always wrote it (x < 0 ? -x : x; keeps the sign of -0.0).
BIODEM_HD inline double lane_abs(double x) { return x < 0.0 ? -x : x; }
template <class R> inline R lane_abs(const R& x) { return LaneOps<R>::abs(x); }
/// Per lane c ? a : b (SIMD lanes only: the scalar laws keep their branches).
template <class M, class R> inline R lane_select(const M& c, const R& a, const R& b) { return LaneOps<R>::select(c, a, b); }
template <class M, class R> inline Vec3T<R> lane_select(const M& c, const Vec3T<R>& a, const Vec3T<R>& b) {
  return {LaneOps<R>::select(c, a.x, b.x), LaneOps<R>::select(c, a.y, b.y), LaneOps<R>::select(c, a.z, b.z)};
}

}  // namespace biodem
