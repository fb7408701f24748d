// The per-body step of bodies in SIMD lanes, 8 at a time with AVX-512F, 4 with AVX2:
// - single-sphere bodies (a sphere at its body's centre with equal principal moments: the glass
//   beads);
// - clumps of n >= 2 spheres (the needles): the sums of their spheres' forces and torques, the
//   kicks, the drift, the free-rotor turn (integrate/rigid_rotation.hpp), the spheres placed.
// The same IEEE operations, in the same order, as the scalar path of
// Simulation::advance_bodies (reduce_and_kick's sums and integrate::half_kick, then
// integrate::kick_and_drift_but_turn, integrate::free_rotation_steps, place_spheres_of and the
// list's displacement test), so the same bits; built without FMA contraction (CMakeLists.txt).
// Included by sim/simulation_step.cpp for the declarations, and by body_lanes8.cpp (AVX-512F) and
// body_lanes4.cpp (AVX2) for the lane code.
#pragma once
#include <cstddef>
#include <cstdint>

#include "core/quat.hpp"
#include "core/vec3.hpp"

namespace biodem::sim {

/// What the lane update reads and writes (the arrays of the body and sphere stores).
struct BodyLaneArrays {
  const std::uint32_t* first_sphere;
  const double* mass_kg;
  const Vec3* inertia_kg_m2;
  Vec3 *body_x, *body_v, *body_w, *body_f, *body_t;
  const Vec3 *sphere_f, *sphere_t;
  Vec3 *sphere_x, *sphere_v, *sphere_w;
  const Vec3* built_x;  // list build positions (when have_built)
  Vec3 gravity;
  double h, dt, limit2;
  bool have_built;
  // Clumps only:
  Quat* orientation = nullptr;
  Vec3* body_l = nullptr;             // lab angular momentum
  const Vec3* offset_body = nullptr;  // each sphere's offset in its body's frame
};

/// Bodies b, b+1, ..., b+7, each a single sphere as above, owning spheres s, s+1, ..., s+7
/// (s = first_sphere[b]), with (KickFirst) or without this step's sums and second half kick;
/// returns 1 when one of their spheres moved more than the list allows (or a position is not
/// finite), else 0. AVX-512F; the caller runs it only where the CPU has it.
template <bool KickFirst> int advance_sphere_bodies_lanes8(const BodyLaneArrays& a, std::size_t b);
/// The same four at a time: AVX2.
template <bool KickFirst> int advance_sphere_bodies_lanes4(const BodyLaneArrays& a, std::size_t b);

/// Bodies b, ..., b+7, each a clump of n >= 2 spheres, owning spheres s, ..., s + 8n - 1 (s =
/// first_sphere[b], body b+l the spheres s + l n, ..., s + l n + n - 1); otherwise as
/// advance_sphere_bodies_lanes8, with the free-rotor turn and the spheres placed by the new
/// orientation. AVX-512F.
template <bool KickFirst> int advance_clump_bodies_lanes8(const BodyLaneArrays& a, std::size_t b, std::uint32_t n);
/// The same four at a time: AVX2.
template <bool KickFirst> int advance_clump_bodies_lanes4(const BodyLaneArrays& a, std::size_t b, std::uint32_t n);

}  // namespace biodem::sim

#if defined(BIODEM_BODY_LANES_IMPL)
#include <cmath>

#include "core/small_angle.hpp"  // kSmallAngleMax
#include "sim/pair_pass_lanes.hpp"  // gather3, the lane types

namespace biodem::sim {

/// Vec3s l = 0..W-1 of a contiguous run (base[0], base[1], ...) as x, y and z lanes, and back.
/// With 8 lanes (AVX-512F): three loads (stores) and six two-source permutes; otherwise lane by
/// lane. Data movement only.
template <class V>
inline Vec3T<V> load_run3(const Vec3* base) {
#if defined(__AVX512F__)
  if constexpr (V::size() == 8) {
    const double* p = &base[0].x;
    const __m512d a = _mm512_loadu_pd(p), b = _mm512_loadu_pd(p + 8), c = _mm512_loadu_pd(p + 16);
    // a = x0 y0 z0 x1 y1 z1 x2 y2, b = z2 x3 y3 z3 x4 y4 z4 x5, c = y5 z5 x6 y6 z6 x7 y7 z7
    const __m512d xs = _mm512_permutex2var_pd(a, _mm512_setr_epi64(0, 3, 6, 9, 12, 15, 0, 0), b);
    const __m512d ys = _mm512_permutex2var_pd(a, _mm512_setr_epi64(1, 4, 7, 10, 13, 0, 0, 0), b);
    const __m512d zs = _mm512_permutex2var_pd(a, _mm512_setr_epi64(2, 5, 8, 11, 14, 0, 0, 0), b);
    return {V(_mm512_permutex2var_pd(xs, _mm512_setr_epi64(0, 1, 2, 3, 4, 5, 10, 13), c)),
            V(_mm512_permutex2var_pd(ys, _mm512_setr_epi64(0, 1, 2, 3, 4, 8, 11, 14), c)),
            V(_mm512_permutex2var_pd(zs, _mm512_setr_epi64(0, 1, 2, 3, 4, 9, 12, 15), c))};
  }
#endif
#if defined(__AVX2__)
  if constexpr (V::size() == 4) {
    const double* p = &base[0].x;
    // a = x0 y0 z0 x1, b = y1 z1 x2 y2, c = z2 x3 y3 z3: blends, then one lane permute each.
    const __m256d a = _mm256_loadu_pd(p), b = _mm256_loadu_pd(p + 4), c = _mm256_loadu_pd(p + 8);
    const __m256d xs = _mm256_blend_pd(_mm256_blend_pd(a, b, 0b0100), c, 0b0010);  // a0 c1 b2 a3
    const __m256d ys = _mm256_blend_pd(_mm256_blend_pd(a, b, 0b1001), c, 0b0100);  // b0 a1 c2 b3
    const __m256d zs = _mm256_blend_pd(_mm256_blend_pd(a, b, 0b0010), c, 0b1001);  // c0 b1 a2 c3
    return {V(_mm256_permute4x64_pd(xs, _MM_SHUFFLE(1, 2, 3, 0))), V(_mm256_permute4x64_pd(ys, _MM_SHUFFLE(2, 3, 0, 1))),
            V(_mm256_permute4x64_pd(zs, _MM_SHUFFLE(3, 0, 1, 2)))};
  }
#endif
  return {V([&](auto l) { return base[l].x; }), V([&](auto l) { return base[l].y; }),
          V([&](auto l) { return base[l].z; })};
}

template <class V>
inline void store_run3(Vec3* base, const Vec3T<V>& v) {
#if defined(__AVX512F__)
  if constexpr (V::size() == 8) {
    double* p = &base[0].x;
    const __m512d x = static_cast<__m512d>(v.x), y = static_cast<__m512d>(v.y), z = static_cast<__m512d>(v.z);
    // x0 y0 z0 x1 y1 z1 x2 y2 | z2 x3 y3 z3 x4 y4 z4 x5 | y5 z5 x6 y6 z6 x7 y7 z7
    const __m512d a = _mm512_permutex2var_pd(x, _mm512_setr_epi64(0, 8, 0, 1, 9, 0, 2, 10), y);
    const __m512d b = _mm512_permutex2var_pd(x, _mm512_setr_epi64(0, 3, 11, 0, 4, 12, 0, 5), y);
    const __m512d c = _mm512_permutex2var_pd(x, _mm512_setr_epi64(13, 0, 6, 14, 0, 7, 15, 0), y);
    _mm512_storeu_pd(p, _mm512_permutex2var_pd(a, _mm512_setr_epi64(0, 1, 8, 3, 4, 9, 6, 7), z));
    _mm512_storeu_pd(p + 8, _mm512_permutex2var_pd(b, _mm512_setr_epi64(10, 1, 2, 11, 4, 5, 12, 7), z));
    _mm512_storeu_pd(p + 16, _mm512_permutex2var_pd(c, _mm512_setr_epi64(0, 13, 2, 3, 14, 5, 6, 15), z));
    return;
  }
#endif
#if defined(__AVX2__)
  if constexpr (V::size() == 4) {
    double* p = &base[0].x;
    const __m256d x = static_cast<__m256d>(v.x), y = static_cast<__m256d>(v.y), z = static_cast<__m256d>(v.z);
    // x0 y0 z0 x1 | y1 z1 x2 y2 | z2 x3 y3 z3
    const __m256d a = _mm256_blend_pd(_mm256_blend_pd(_mm256_permute4x64_pd(x, _MM_SHUFFLE(1, 0, 0, 0)),
                                                      _mm256_permute4x64_pd(y, _MM_SHUFFLE(0, 0, 0, 0)), 0b0010),
                                      _mm256_permute4x64_pd(z, _MM_SHUFFLE(0, 0, 0, 0)), 0b0100);
    const __m256d b = _mm256_blend_pd(_mm256_blend_pd(_mm256_permute4x64_pd(y, _MM_SHUFFLE(2, 1, 1, 1)),
                                                      _mm256_permute4x64_pd(z, _MM_SHUFFLE(1, 1, 1, 1)), 0b0010),
                                      _mm256_permute4x64_pd(x, _MM_SHUFFLE(2, 2, 2, 2)), 0b0100);
    const __m256d c = _mm256_blend_pd(_mm256_blend_pd(_mm256_permute4x64_pd(z, _MM_SHUFFLE(3, 2, 2, 2)),
                                                      _mm256_permute4x64_pd(x, _MM_SHUFFLE(3, 3, 3, 3)), 0b0010),
                                      _mm256_permute4x64_pd(y, _MM_SHUFFLE(3, 3, 3, 3)), 0b0100);
    _mm256_storeu_pd(p, a);
    _mm256_storeu_pd(p + 4, b);
    _mm256_storeu_pd(p + 8, c);
    return;
  }
#endif
  alignas(64) double x[V::size()], y[V::size()], z[V::size()];
  v.x.copy_to(x, stdx::vector_aligned);
  v.y.copy_to(y, stdx::vector_aligned);
  v.z.copy_to(z, stdx::vector_aligned);
  for (std::size_t l = 0; l < V::size(); ++l) base[l] = Vec3{x[l], y[l], z[l]};
}

template <class V, bool KickFirst>
inline int advance_sphere_bodies(const BodyLaneArrays& a, std::size_t b) {
  using V3 = Vec3T<V>;
  const std::size_t s = a.first_sphere[b];  // the caller checked that bodies b.. own spheres s..
  const V mass(&a.mass_kg[b], stdx::element_aligned);
  const V inertia = load_run3<V>(a.inertia_kg_m2 + b).x;
  const V h(a.h), dt(a.dt);
  V3 x = load_run3<V>(a.body_x + b), v = load_run3<V>(a.body_v + b), wv = load_run3<V>(a.body_w + b), f, t;
  if constexpr (KickFirst) {
    const V3 fs = load_run3<V>(a.sphere_f + s);
    f = V3{mass * V(a.gravity.x), mass * V(a.gravity.y), mass * V(a.gravity.z)};
    f += fs;
    t += load_run3<V>(a.sphere_t + s) + cross(load_run3<V>(a.sphere_x + s) - x, fs);
    store_run3<V>(a.body_f + b, f);
    store_run3<V>(a.body_t + b, t);
    v += (h / mass) * f;
    wv += (h / inertia) * t;
  } else {
    f = load_run3<V>(a.body_f + b);
    t = load_run3<V>(a.body_t + b);
  }
  const V inv_m = V(1.0) / mass;
  v += (h * inv_m) * f;
  x += dt * v;
  wv += (h / inertia) * t;
  store_run3<V>(a.body_x + b, x);
  store_run3<V>(a.body_v + b, v);
  store_run3<V>(a.body_w + b, wv);
  store_run3<V>(a.sphere_x + s, x);
  store_run3<V>(a.sphere_v + s, v);
  store_run3<V>(a.sphere_w + s, wv);
  if (!a.have_built) return 0;
  const V d2 = norm2(x - load_run3<V>(a.built_x + s));
  return stdx::any_of(!(d2 <= V(a.limit2))) ? 1 : 0;  // NaN also triggers a (failing) build
}


/// A quaternion per lane (structure of arrays).
template <class V>
struct QuatLanes {
  V w, x, y, z;
};

/// to_matrix (core/quat.hpp) per lane: the same operations in the same order. Row-major.
template <class V>
inline void to_matrix_lanes(const QuatLanes<V>& q, V (&r)[9]) {
  const V ww = q.w * q.w, xx = q.x * q.x, yy = q.y * q.y, zz = q.z * q.z;
  const V xy = q.x * q.y, xz = q.x * q.z, yz = q.y * q.z, wx = q.w * q.x, wy = q.w * q.y, wz = q.w * q.z;
  const V two(2.0);
  r[0] = ww + xx - yy - zz;
  r[1] = two * (xy - wz);
  r[2] = two * (xz + wy);
  r[3] = two * (xy + wz);
  r[4] = ww - xx + yy - zz;
  r[5] = two * (yz - wx);
  r[6] = two * (xz - wy);
  r[7] = two * (yz + wx);
  r[8] = ww - xx - yy + zz;
}
/// Mat3 * Vec3 and transpose(Mat3) * Vec3 (core/mat3.hpp) per lane.
template <class V>
inline Vec3T<V> times(const V (&r)[9], const Vec3T<V>& v) {
  return {r[0] * v.x + r[1] * v.y + r[2] * v.z, r[3] * v.x + r[4] * v.y + r[5] * v.z,
          r[6] * v.x + r[7] * v.y + r[8] * v.z};
}
template <class V>
inline Vec3T<V> times_transposed(const V (&r)[9], const Vec3T<V>& v) {
  return {r[0] * v.x + r[3] * v.y + r[6] * v.z, r[1] * v.x + r[4] * v.y + r[7] * v.z,
          r[2] * v.x + r[5] * v.y + r[8] * v.z};
}

/// sincos_small_angle (core/small_angle.hpp) per lane: the series where the scalar function
/// takes it, and the library's sine and cosine, lane by lane, where it does not (angles above
/// 1/16 rad in one step, and NaN).
template <class V>
inline void sincos_small_angle_lanes(const V& x, V& s, V& c) {
  const V x2 = x * x;
  s = x * (V(1.0) + x2 * (V(-1.0 / 6.0) + x2 * (V(1.0 / 120.0) + x2 * (V(-1.0 / 5040.0) + x2 * V(1.0 / 362880.0)))));
  c = V(1.0) +
      x2 * (V(-0.5) + x2 * (V(1.0 / 24.0) + x2 * (V(-1.0 / 720.0) + x2 * (V(1.0 / 40320.0) + x2 * V(-1.0 / 3628800.0)))));
  const auto small = x2 <= V(kSmallAngleMax * kSmallAngleMax);
  if (stdx::all_of(small)) return;
  for (std::size_t l = 0; l < V::size(); ++l)
    if (!small[l]) {
      const double xl = x[l];
      s[l] = std::sin(xl);
      c[l] = std::cos(xl);
    }
}

/// integrate::free_rotation_steps per lane: the body-frame angular momentum pi, the five
/// sub-steps R1(h/2) R2(h/2) R3(h) R2(h/2) R1(h/2), the quaternion normalised, and the lab
/// angular velocity; the same operations in the same order.
template <class V>
inline Vec3T<V> free_rotation_lanes(QuatLanes<V>& q, const Vec3T<V>& l, const Vec3T<V>& inertia, double h) {
  V r[9];
  to_matrix_lanes(q, r);
  const Vec3T<V> pi0 = times_transposed(r, l);
  V pi[3] = {pi0.x, pi0.y, pi0.z};
  const V inv_i[3] = {V(1.0) / inertia.x, V(1.0) / inertia.y, V(1.0) / inertia.z};
  auto sub = [&](int k, double hk) {
    const int a = (k + 1) % 3, b = (k + 2) % 3;
    const V half = V(0.5 * hk) * pi[k] * inv_i[k];
    V s2, c2;
    sincos_small_angle_lanes(half, s2, c2);
    const V c = c2 * c2 - s2 * s2, s = V(2.0) * s2 * c2;
    const V pa = pi[a], pb = pi[b];
    pi[a] = c * pa + s * pb;
    pi[b] = -s * pa + c * pb;
    V v[3] = {q.x, q.y, q.z};
    const V w = q.w, vk = v[k], va = v[a], vb = v[b];
    q.w = c2 * w - s2 * vk;
    v[k] = c2 * vk + s2 * w;
    v[a] = c2 * va + s2 * vb;
    v[b] = c2 * vb - s2 * va;
    q.x = v[0];
    q.y = v[1];
    q.z = v[2];
  };
  sub(0, 0.5 * h);
  sub(1, 0.5 * h);
  sub(2, h);
  sub(1, 0.5 * h);
  sub(0, 0.5 * h);
  const V n = stdx::sqrt(q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z);  // normalized()
  q = QuatLanes<V>{q.w / n, q.x / n, q.y / n, q.z / n};
  to_matrix_lanes(q, r);
  return times(r, Vec3T<V>{pi[0] * inv_i[0], pi[1] * inv_i[1], pi[2] * inv_i[2]});
}

/// Vec3s base[idx[l]] of lane l written back (lane by lane).
template <class V>
inline void scatter3(Vec3* base, const std::uint32_t* idx, const Vec3T<V>& v) {
  for (std::size_t l = 0; l < V::size(); ++l) base[idx[l]] = Vec3{v.x[l], v.y[l], v.z[l]};
}

template <class V, bool KickFirst>
inline int advance_clump_bodies(const BodyLaneArrays& a, std::size_t b, std::uint32_t n) {
  using V3 = Vec3T<V>;
  constexpr std::size_t W = V::size();
  const std::uint32_t s = a.first_sphere[b];  // the caller checked that bodies b.. own spheres s.. (n each)
  const V mass(&a.mass_kg[b], stdx::element_aligned);
  const V3 inertia = load_run3<V>(a.inertia_kg_m2 + b);
  const V h(a.h), dt(a.dt);
  V3 x = load_run3<V>(a.body_x + b), v = load_run3<V>(a.body_v + b), l = load_run3<V>(a.body_l + b), f, t;
  std::uint32_t idx[W];
  auto sphere_indices = [&](std::uint32_t k) {
    for (std::size_t j = 0; j < W; ++j) idx[j] = s + static_cast<std::uint32_t>(j) * n + k;
  };
  if constexpr (KickFirst) {  // reduce_and_kick's sums, then half_kick's clump branch
    f = V3{mass * V(a.gravity.x), mass * V(a.gravity.y), mass * V(a.gravity.z)};
    for (std::uint32_t k = 0; k < n; ++k) {
      sphere_indices(k);
      const V3 fs = gather3<V>(&a.sphere_f[0].x, 3, idx);
      f += fs;
      t += gather3<V>(&a.sphere_t[0].x, 3, idx) + cross(gather3<V>(&a.sphere_x[0].x, 3, idx) - x, fs);
    }
    store_run3<V>(a.body_f + b, f);
    store_run3<V>(a.body_t + b, t);
    v += (h / mass) * f;
    l += h * t;
  } else {
    f = load_run3<V>(a.body_f + b);
    t = load_run3<V>(a.body_t + b);
  }
  const V inv_m = V(1.0) / mass;  // integrate::kick_and_drift_but_turn, clump branch
  v += (h * inv_m) * f;
  x += dt * v;
  l += h * t;
  store_run3<V>(a.body_x + b, x);
  store_run3<V>(a.body_v + b, v);
  store_run3<V>(a.body_l + b, l);
  QuatLanes<V> q{V([&](auto j) { return a.orientation[b + j].w; }), V([&](auto j) { return a.orientation[b + j].x; }),
                 V([&](auto j) { return a.orientation[b + j].y; }), V([&](auto j) { return a.orientation[b + j].z; })};
  const V3 w = free_rotation_lanes(q, l, inertia, a.dt);
  for (std::size_t j = 0; j < W; ++j) a.orientation[b + j] = Quat{q.w[j], q.x[j], q.y[j], q.z[j]};
  store_run3<V>(a.body_w + b, w);
  V r[9];  // place_spheres_of
  to_matrix_lanes(q, r);
  typename V::mask_type moved(false);
  for (std::uint32_t k = 0; k < n; ++k) {
    sphere_indices(k);
    const V3 arm = times(r, gather3<V>(&a.offset_body[0].x, 3, idx));
    const V3 xs = x + arm;
    scatter3<V>(a.sphere_x, idx, xs);
    scatter3<V>(a.sphere_v, idx, v + cross(w, arm));
    scatter3<V>(a.sphere_w, idx, w);
    if (a.have_built) moved = moved || !(norm2(xs - gather3<V>(&a.built_x[0].x, 3, idx)) <= V(a.limit2));
  }
  return stdx::any_of(moved) ? 1 : 0;  // NaN also triggers a (failing) build
}

}  // namespace biodem::sim
#endif
