// The lane evaluator of a staged pair batch (sim/pair_pass.hpp), for one SIMD type V. Included
// only by the pair_pass_lanes*.cpp translation units, each built for its instruction set; it
// instantiates the shared contact laws with V and nothing with plain doubles, so no function
// compiled for a wider instruction set can stand in for a baseline one at link time.
#pragma once
#include "contact/contact_model.hpp"
#include "core/lanes_simd.hpp"
#include "sim/pair_pass.hpp"
#if defined(__AVX__)
#include <immintrin.h>
#endif

namespace biodem::sim {

/// The three doubles at base + stride * idx[l] (a Vec3 of an array of structures) for each
/// lane l, as x, y and z lanes. Data movement only, so every kernel gets the same bits. With 8
/// lanes (AVX-512F): eight masked loads of three doubles (the masked-out lanes are not read),
/// interleaved by four unpacks and three permutes, instead of 24 loads and 21 inserts; with 4
/// lanes (AVX), four masked loads, four unpacks and three lane permutes.
static_assert(sizeof(Vec3) == 3 * sizeof(double) && sizeof(contact::ContactHistory) % sizeof(double) == 0,
              "gather3 reads Vec3 and ContactHistory as arrays of doubles");

template <class V>
inline Vec3T<V> gather3(const double* base, std::size_t stride, const std::uint32_t* idx) {
#if defined(__AVX512F__)
  if constexpr (V::size() == 8) {
    auto at = [&](int l) { return base + stride * idx[l]; };
    // Lanes 0-2 from one Vec3, lanes 4-6 from the next; the address of the second is taken 4
    // doubles early (as an integer: lanes 0-3 of that load are masked out and never touched).
    auto pair = [&](int l) {
      const __m512d lo = _mm512_maskz_loadu_pd(0x07, at(l));
      const auto hi = reinterpret_cast<const double*>(reinterpret_cast<std::uintptr_t>(at(l + 1)) - 4 * sizeof(double));
      return _mm512_mask_loadu_pd(lo, 0x70, hi);
    };
    const __m512d a0 = pair(0), a1 = pair(2), a2 = pair(4), a3 = pair(6);
    // a_m = [x y z 0 | x' y' z' 0] of lanes 2m and 2m + 1.
    const __m512d t0 = _mm512_unpacklo_pd(a0, a1);  // x0 x2 z0 z2 x1 x3 z1 z3
    const __m512d t1 = _mm512_unpackhi_pd(a0, a1);  // y0 y2 0 0 y1 y3 0 0
    const __m512d t2 = _mm512_unpacklo_pd(a2, a3);  // x4 x6 z4 z6 x5 x7 z5 z7
    const __m512d t3 = _mm512_unpackhi_pd(a2, a3);  // y4 y6 0 0 y5 y7 0 0
    const __m512i first = _mm512_setr_epi64(0, 4, 1, 5, 8, 12, 9, 13);
    const __m512i second = _mm512_setr_epi64(2, 6, 3, 7, 10, 14, 11, 15);
    return {V(_mm512_permutex2var_pd(t0, first, t2)), V(_mm512_permutex2var_pd(t1, first, t3)),
            V(_mm512_permutex2var_pd(t0, second, t2))};
  }
#endif
#if defined(__AVX__)
  if constexpr (V::size() == 4) {
    const __m256i xyz = _mm256_setr_epi64x(-1, -1, -1, 0);
    auto load = [&](int l) { return _mm256_maskload_pd(base + stride * idx[l], xyz); };  // x y z 0
    const __m256d r0 = load(0), r1 = load(1), r2 = load(2), r3 = load(3);
    const __m256d t0 = _mm256_unpacklo_pd(r0, r1);  // x0 x1 z0 z1
    const __m256d t1 = _mm256_unpackhi_pd(r0, r1);  // y0 y1 0 0
    const __m256d t2 = _mm256_unpacklo_pd(r2, r3);  // x2 x3 z2 z3
    const __m256d t3 = _mm256_unpackhi_pd(r2, r3);  // y2 y3 0 0
    return {V(_mm256_permute2f128_pd(t0, t2, 0x20)), V(_mm256_permute2f128_pd(t1, t3, 0x20)),
            V(_mm256_permute2f128_pd(t0, t2, 0x31))};
  }
#endif
  auto lane = [&](int c) { return V([&](auto l) { return base[stride * idx[l] + c]; }); };
  return {lane(0), lane(1), lane(2)};
}

/// The pair parameters of W contacts, one per lane (pair and wall batches).
template <class V, bool Cohesion, bool Rolling>
inline contact::PairParamsT<V> lane_params(const contact::PairParams* const* params, bool tangential_reduce) {
  // Most cases have one pair of materials, or contacts of one pair in a row: when the W lanes
  // share one parameter set, each field is broadcast instead of gathered lane by lane.
  bool shared = true;
  for (std::size_t l = 1; l < V::size(); ++l) shared &= params[l] == params[0];
  auto param = [&](double contact::PairParams::*field) {
    return shared ? V(params[0]->*field) : V([&](auto l) { return params[l]->*field; });
  };
  contact::PairParamsT<V> p;
  p.y_eff_pa = param(&contact::PairParams::y_eff_pa);
  p.g_eff_pa = param(&contact::PairParams::g_eff_pa);
  p.beta = param(&contact::PairParams::beta);
  p.friction = param(&contact::PairParams::friction);
  if constexpr (Rolling) p.rolling_friction = param(&contact::PairParams::rolling_friction);
  if constexpr (Cohesion) p.cohesion_energy_density_j_m3 = param(&contact::PairParams::cohesion_energy_density_j_m3);
  p.tangential_reduce = tangential_reduce;
  return p;
}

template <class V, bool Cohesion, bool Rolling>
inline void evaluate_batch(PairBatch& b) {
  using V3 = Vec3T<V>;
  using F = PairBatch;
  constexpr int w = static_cast<int>(V::size());
  const PairPassData& d = *b.data;
  const contact::ContactHistory* history = d.list->history.data();
  const bool tangential_reduce = b.params[0]->tangential_reduce;  // one setting for every pair of a case
  for (int g = 0; g < b.n; g += w) {
    auto ld = [&](int f) { return V(&b.a[f][g], stdx::vector_aligned); };
    auto gather = [&](const double* base, const std::uint32_t* idx) {
      return V([&](auto l) { return base[idx[g + l]]; });
    };
    auto gather3 = [&](const Vec3* base, const std::uint32_t* idx) {
      return sim::gather3<V>(&base[0].x, 3, idx + g);
    };
    const V ri = gather(d.radius_m, b.i), rj = gather(d.radius_m, b.j);
    using std::sqrt;
    const V dist = sqrt(ld(F::Dist2));
    const contact::ContactGeometryT<V> geo = contact::sphere_sphere_geometry<V>(
        V3{ld(F::Dx), ld(F::Dy), ld(F::Dz)}, dist, ri, rj, gather(d.body_mass_kg, b.i), gather(d.body_mass_kg, b.j),
        gather3(d.velocity_m_s, b.i), gather3(d.velocity_m_s, b.j), gather3(d.angular_velocity_rad_s, b.i),
        gather3(d.angular_velocity_rad_s, b.j));
    const contact::PairParamsT<V> p = lane_params<V, Cohesion, Rolling>(b.params + g, tangential_reduce);
    contact::ContactHistoryT<V> h;
    constexpr std::size_t kHistoryStride = sizeof(contact::ContactHistory) / sizeof(double);
    h.xi = sim::gather3<V>(&history[0].xi.x, kHistoryStride, b.k + g);
    if constexpr (Rolling) h.m_r = sim::gather3<V>(&history[0].m_r.x, kHistoryStride, b.k + g);
    const V area = Cohesion ? contact::sjkr_area_sphere_sphere(ri, rj, dist) : V(0.0);
    const contact::ContactOutputT<V> out = contact::evaluate_contact<Cohesion, Rolling>(geo, p, h, area, d.dt_s);
    auto st = [&](int f, const V& v) { v.copy_to(&b.a[f][g], stdx::vector_aligned); };
    auto st3 = [&](int f, const V3& v) {
      st(f, v.x);
      st(f + 1, v.y);
      st(f + 2, v.z);
    };
    st3(F::Fx, out.force_i);
    st3(F::Tix, out.torque_i);
    st3(F::Tjx, out.torque_j);
    st3(F::Xix, h.xi);
    if constexpr (Rolling) st3(F::Mrx, h.m_r);
  }
}

/// The sphere-wall contacts of a wall batch, W at a time (the same operations as the scalar wall
/// loop of Simulation::gather_and_walls after the wall's geometry).
template <class V, bool Cohesion, bool Rolling>
inline void evaluate_wall_batch(WallBatch& b) {
  using V3 = Vec3T<V>;
  using F = WallBatch;
  constexpr int w = static_cast<int>(V::size());
  const state::SphereStore& s = *b.spheres;
  const bool tangential_reduce = b.params[0]->tangential_reduce;
  for (int g = 0; g < b.n; g += w) {
    auto ld = [&](int f) { return V(&b.a[f][g], stdx::vector_aligned); };
    auto ld3 = [&](int f) { return V3{ld(f), ld(f + 1), ld(f + 2)}; };
    auto gather = [&](const std::vector<double>& base) { return V([&](auto l) { return base[b.i[g + l]]; }); };
    auto gather3 = [&](const std::vector<Vec3>& base) { return sim::gather3<V>(&base[0].x, 3, b.i + g); };
    const V ri = gather(s.radius_m), gap = ld(F::Gap);
    const contact::ContactGeometryT<V> geo = contact::sphere_wall_geometry<V>(
        ld3(F::Nx), gap, ri, gather(s.body_mass_kg), gather3(s.velocity_m_s), gather3(s.angular_velocity_rad_s),
        ld3(F::Vwx), ld3(F::Wwx));
    const contact::PairParamsT<V> p = lane_params<V, Cohesion, Rolling>(b.params + g, tangential_reduce);
    contact::ContactHistoryT<V> h;
    h.xi = ld3(F::Xix);
    if constexpr (Rolling) h.m_r = ld3(F::Mrx);
    const V area = Cohesion ? contact::sjkr_area_sphere_wall<V>(ri, gap) : V(0.0);
    const contact::ContactOutputT<V> out = contact::evaluate_contact<Cohesion, Rolling>(geo, p, h, area, b.dt_s);
    auto st = [&](int f, const V& v) { v.copy_to(&b.a[f][g], stdx::vector_aligned); };
    auto st3 = [&](int f, const V3& v) {
      st(f, v.x);
      st(f + 1, v.y);
      st(f + 2, v.z);
    };
    st3(F::Fx, out.force_i);
    st3(F::Tix, out.torque_i);
    st3(F::Xix, h.xi);
    if constexpr (Rolling) st3(F::Mrx, h.m_r);
  }
}

}  // namespace biodem::sim
