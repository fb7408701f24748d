// Conservation laws of the elastic, frictionless gas (SPEC 10: "energy conservation for
// e = 1"), driven through the Simulation with several hundred polydisperse spheres.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <unordered_set>
#include <vector>

#include "physics_support.hpp"

using namespace biodem;
using namespace biodem::phys;

namespace {

constexpr int kSide = 7;                 // 7^3 = 343 spheres on a jittered lattice
constexpr double kSpacing = 2.3e-3;      // lattice spacing, m
constexpr double kBox = kSide * kSpacing; // 16.1 mm
constexpr double kRmin = 0.8e-3, kRmax = 1.0e-3;
const Material kPolymer{5e8, 0.3, 1200.0};

double uniform(std::mt19937_64& g) { return static_cast<double>(g() >> 11) * 0x1.0p-53; }

/// Dense gas: volume fraction ~0.25, velocities uniform in [-1, 1] m/s per component.
/// Templates: one per sphere radius (polydisperse).
sim::Simulation make_gas(bool walls, bool periodic) {
  std::mt19937_64 gen(12345);
  std::vector<double> radii;
  std::vector<shapes::ClumpTemplate> templates;
  for (int k = 0; k < kSide * kSide * kSide; ++k) {
    radii.push_back(kRmin + (kRmax - kRmin) * uniform(gen));
    templates.push_back(sphere_template(radii.back()));
  }
  SimSetup su;
  su.particle = kPolymer;
  su.wall = kPolymer;
  su.particle_particle = {1.0, 0.0, 0.0, 0.0};
  su.particle_wall = su.particle_particle;
  su.templates = templates;
  // Shortest contact: two of the smallest spheres at the largest possible approach speed
  // (2 sqrt(3) m/s < 4 m/s); 50 steps per such contact.
  const double m_min = sphere_mass_kg(kRmin, kPolymer.density_kg_m3);
  su.dt_s = hertz_contact_time_s(0.5 * m_min, 0.5 * kRmin, effective_young_pa(kPolymer, kPolymer), 4.0) / 50.0;
  sim::Simulation s = make_simulation(su);
  if (walls) {
    for (int a = 0; a < 3; ++a) {
      Vec3 n;
      n[a] = 1.0;
      Vec3 far;
      far[a] = kBox;
      s.add_wall(plane_wall({0, 0, 0}, n));
      s.add_wall(plane_wall(far, -n));
    }
  }
  if (periodic) {
    neighbor::Domain d;
    d.periodic = {true, true, true};
    d.lo_m = {0, 0, 0};
    d.hi_m = {kBox, kBox, kBox};
    s.set_domain(d);
  }
  int k = 0;
  for (int i = 0; i < kSide; ++i)
    for (int j = 0; j < kSide; ++j)
      for (int l = 0; l < kSide; ++l, ++k) {
        // Jitter keeps every sphere clear of its neighbours and the walls: 2 * 1.0 + 2 * 0.1 < 2.3 mm.
        const Vec3 x{(i + 0.5) * kSpacing + 0.1e-3 * (2 * uniform(gen) - 1),
                     (j + 0.5) * kSpacing + 0.1e-3 * (2 * uniform(gen) - 1),
                     (l + 0.5) * kSpacing + 0.1e-3 * (2 * uniform(gen) - 1)};
        const Vec3 v{2 * uniform(gen) - 1, 2 * uniform(gen) - 1, 2 * uniform(gen) - 1};
        add_particle(s, static_cast<std::uint32_t>(k), x, v);
      }
  return s;
}

/// Touching pairs and wall contacts after the last step, as keys made of stable body ids (the
/// engine renumbers bodies when it sorts them spatially; one sphere per body here).
std::unordered_set<std::uint64_t> touching_keys(sim::Simulation& s) {
  std::unordered_set<std::uint64_t> keys;
  const auto& L = s.neighbor_list();
  const std::uint64_t n = s.spheres().size(), nw = s.walls().size();
  const auto id = [&](std::uint64_t sphere) -> std::uint64_t { return s.bodies().id[s.spheres().body[sphere]]; };
  for (std::uint64_t i = 0; i < n; ++i)
    for (std::uint32_t k = L.row_start[i]; k < L.row_start[i + 1]; ++k)
      if (L.touching[k]) {
        const std::uint64_t a = id(i), b = id(L.j[k]);
        keys.insert(std::min(a, b) * n + std::max(a, b));
      }
  const auto& wc = s.wall_contacts();
  for (std::uint64_t i = 0; i < n; ++i)
    for (std::uint32_t q = wc.start[i]; q < wc.start[i + 1]; ++q)
      if (wc.touching[q]) keys.insert(n * n + id(i) * nw + wc.wall[q]);
  return keys;
}

}  // namespace

// 6a. Closed box of six planes, e = 1, mu = 0, no gravity: total energy = kinetic + Hertz
// elastic energy of the open contacts is conserved. Tolerance 0.5 % (the brief's) on the largest
// deviation over the run: velocity Verlet is symplectic for these conservative forces (no
// damping, no friction), so the energy error is a bounded fluctuation of order (dt/t_c)^2
// during contacts, with no drift; 50 steps per fastest contact keep it ~1e-4.
TEST(Conservation, ElasticFrictionlessGasKeepsTotalEnergy) {
  const ScopedThreads one_thread(1);  // multi-thread path: test_determinism.cpp
  sim::Simulation s = make_gas(/*walls=*/true, /*periodic=*/false);
  s.refresh();
  const double e0 = s.kinetic_energy_j() + s.elastic_energy_j();
  ASSERT_GT(e0, 0.0);
  std::unordered_set<std::uint64_t> prev = touching_keys(s);
  std::uint64_t pair_collisions = 0, wall_collisions = 0;
  const std::uint64_t n = s.spheres().size();
  double worst = 0.0;
  const auto n_steps = static_cast<std::uint64_t>(0.012 / s.dt_s());
  for (std::uint64_t k = 0; k < n_steps; ++k) {
    s.step();
    const double e = s.kinetic_energy_j() + s.elastic_energy_j();
    worst = std::max(worst, std::abs(e / e0 - 1.0));
    std::unordered_set<std::uint64_t> now = touching_keys(s);
    for (const auto key : now)
      if (!prev.count(key)) (key < n * n ? pair_collisions : wall_collisions)++;
    prev.swap(now);
  }
  const double per_sphere = (2.0 * pair_collisions + wall_collisions) / static_cast<double>(n);
  std::printf("[measured] gas: %llu spheres, %llu steps, %llu pair + %llu wall collisions = %.1f per sphere\n",
              static_cast<unsigned long long>(n), static_cast<unsigned long long>(n_steps),
              static_cast<unsigned long long>(pair_collisions), static_cast<unsigned long long>(wall_collisions),
              per_sphere);
  report("gas: largest relative energy deviation", worst, 0.0);
  EXPECT_GT(per_sphere, 20.0);  // "many collisions"
  EXPECT_LT(worst, 5e-3);
}

// 6b. Wall-free, fully periodic box: every pair force acts as +F on i and -F on j, so the total
// linear momentum changes only by round-off. Tolerance: 1e-12 of sum m |v| (a sum of ~1e3
// terms of relative precision 1e-16 per step, over ~13 000 steps, stays far below it).
TEST(Conservation, PeriodicGasKeepsLinearMomentum) {
  const ScopedThreads one_thread(1);
  sim::Simulation s = make_gas(/*walls=*/false, /*periodic=*/true);
  s.refresh();
  const Vec3 p0 = s.linear_momentum();
  double scale = 0.0;
  for (std::size_t b = 0; b < s.bodies().size(); ++b) scale += s.bodies().mass_kg[b] * norm(s.bodies().velocity_m_s[b]);
  double worst = 0.0;
  std::uint64_t contact_steps = 0;
  const auto n_steps = static_cast<std::uint64_t>(0.005 / s.dt_s());  // ~5 mm of travel at 1 m/s
  for (std::uint64_t k = 0; k < n_steps; ++k) {
    s.step();
    worst = std::max(worst, norm(s.linear_momentum() - p0) / scale);
    contact_steps += s.contact_count();
  }
  // Spheres cross the periodic boundaries (positions are never wrapped) and collide.
  double max_out = 0.0;
  for (const auto& x : s.bodies().position_m)
    for (int a = 0; a < 3; ++a) max_out = std::max({max_out, -x[a], x[a] - kBox});
  report("periodic gas: largest |P - P0| / sum m|v|", worst, 0.0);
  EXPECT_GT(contact_steps, 1000u);
  EXPECT_GT(max_out, 0.0) << "no sphere crossed a periodic boundary";
  EXPECT_LT(worst, 1e-12);
}
