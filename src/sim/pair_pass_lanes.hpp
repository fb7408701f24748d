// The lane evaluator of a staged pair batch (sim/pair_pass.hpp), for one SIMD type V. Included
// only by the pair_pass_lanes*.cpp translation units, each built for its instruction set; it
// instantiates the shared contact laws with V and nothing with plain doubles, so no function
// compiled for a wider instruction set can stand in for a baseline one at link time.
#pragma once
#include "contact/contact_model.hpp"
#include "core/lanes_simd.hpp"
#include "sim/pair_pass.hpp"

namespace biodem::sim {

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
      return V3{V([&](auto l) { return base[idx[g + l]].x; }), V([&](auto l) { return base[idx[g + l]].y; }),
                V([&](auto l) { return base[idx[g + l]].z; })};
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
    h.xi = V3{V([&](auto l) { return history[b.k[g + l]].xi.x; }), V([&](auto l) { return history[b.k[g + l]].xi.y; }),
              V([&](auto l) { return history[b.k[g + l]].xi.z; })};
    if constexpr (Rolling)
      h.m_r = V3{V([&](auto l) { return history[b.k[g + l]].m_r.x; }),
                 V([&](auto l) { return history[b.k[g + l]].m_r.y; }),
                 V([&](auto l) { return history[b.k[g + l]].m_r.z; })};
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
    auto gather3 = [&](const std::vector<Vec3>& base) {
      return V3{V([&](auto l) { return base[b.i[g + l]].x; }), V([&](auto l) { return base[b.i[g + l]].y; }),
                V([&](auto l) { return base[b.i[g + l]].z; })};
    };
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
