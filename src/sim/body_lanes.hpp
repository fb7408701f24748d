// The per-body step of single-sphere bodies (a sphere at its body's centre with equal principal
// moments: the glass beads), 8 bodies at a time in AVX-512F lanes. The same IEEE operations, in the
// same order, as the scalar path of Simulation::advance_bodies (reduce_and_kick's sums and
// integrate::half_kick, then integrate::kick_and_drift_but_turn, the placement and the list's
// displacement test), so the same bits; built without FMA contraction (CMakeLists.txt).
// Included by sim/simulation_step.cpp for the declarations, and by body_lanes8.cpp (built
// for AVX-512F) for the lane code.
#pragma once
#include <cstddef>
#include <cstdint>

#include "core/vec3.hpp"

namespace biodem::sim {

/// What the lane update reads and writes (the arrays of the body and sphere stores).
struct SphereBodyArrays {
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
};

/// Bodies b, b+1, ..., b+7, each a single sphere as above, owning spheres s, s+1, ..., s+7
/// (s = first_sphere[b]), with (KickFirst) or without this step's sums and second half kick;
/// returns 1 when one of their spheres moved more than the list allows (or a position is not
/// finite), else 0. AVX-512F; the caller runs it only where the CPU has it.
template <bool KickFirst> int advance_sphere_bodies_lanes8(const SphereBodyArrays& a, std::size_t b);
/// The same four at a time: AVX2.
template <bool KickFirst> int advance_sphere_bodies_lanes4(const SphereBodyArrays& a, std::size_t b);

}  // namespace biodem::sim

#if defined(BIODEM_BODY_LANES_IMPL)
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
inline int advance_sphere_bodies(const SphereBodyArrays& a, std::size_t b) {
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

}  // namespace biodem::sim
#endif
