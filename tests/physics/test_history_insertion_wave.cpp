// Contact history across insertion waves (issue 10, item 1): adding bodies to a running
// simulation must not reset the tangential spring of pairs already in contact. Two spheres in a
// frictional oblique impact (sliding: tan(theta) = 2.5 > 3.5 mu (1 + e) = 2.1); in the middle of
// the contact a third body is added 10 cm away. The tangential force on the first sphere in the
// steps after the addition is compared with a run without it. Before the fix the spring restarted
// from zero: F_t changed by 97 % in the step after the addition, and the spin after the impact
// came out 3.5 % low. Now both are identical to the run without the addition (measured: 0).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>

#include "physics_support.hpp"

using namespace biodem;
using namespace biodem::phys;

namespace {

constexpr double kR = 1e-3;
const Material kMat{1e8, 0.3, 1000.0};

sim::Simulation make_pair_scene() {
  SimSetup su;
  su.particle = kMat;
  su.wall = kMat;
  su.particle_particle = {1.0, 0.3, 0.0, 0.0};  // e = 1: no damping, so F_n depends on positions only
  su.particle_wall = su.particle_particle;
  su.templates = {sphere_template(kR)};
  su.dt_s = 1e-7;  // Hertz contact time ~ 80 us: ~800 steps
  sim::Simulation s = make_simulation(su);
  add_particle(s, 0, {0, 0, 0});
  add_particle(s, 0, {2 * kR + 1e-6, 0, 0}, {-0.2, 0.5, 0});
  return s;
}

std::size_t index_of(const sim::Simulation& s, std::uint32_t id) {
  for (std::size_t b = 0; b < s.bodies().size(); ++b)
    if (s.bodies().id[b] == id) return b;
  ADD_FAILURE() << "body " << id << " not found";
  return 0;
}

/// Tangential part of the contact force on body 0 (normal along the line of centres).
Vec3 tangential_force(const sim::Simulation& s) {
  const std::size_t a = index_of(s, 0), b = index_of(s, 1);
  const Vec3 n = normalized(s.bodies().position_m[b] - s.bodies().position_m[a]);
  const Vec3 f = s.bodies().force_n[a];
  return f - dot(f, n) * n;
}

}  // namespace

TEST(ContactHistory, TangentialForceUnchangedWhenABodyIsAddedDuringContact) {
  ScopedThreads one(1);
  sim::Simulation ref = make_pair_scene(), run = make_pair_scene();
  // Into the contact: 300 steps after first touch (about 40 % of the contact time).
  int touching_steps = 0;
  while (touching_steps < 300) {
    ref.step();
    run.step();
    if (ref.contact_count() > 0) ++touching_steps;
    ASSERT_LT(ref.step_count(), 100000u);
  }
  const double ft_before = norm(tangential_force(ref));
  ASSERT_GT(ft_before, 0.0);
  add_particle(run, 0, {0.1, 0.1, 0.1});  // the second "wave": far from the pair
  double worst = 0.0;
  for (int k = 0; k < 20; ++k) {
    ref.step();
    run.step();
    const Vec3 fr = tangential_force(ref), ft = tangential_force(run);
    worst = std::max(worst, norm(ft - fr) / norm(fr));
  }
  report("relative change of F_t in the 20 steps after adding a body", worst, 0.0);
  EXPECT_LT(worst, 1e-6);
  // The whole impact: the spin of the first sphere after the contact.
  while (ref.contact_count() > 0 || run.contact_count() > 0) {
    ref.step();
    run.step();
    ASSERT_LT(ref.step_count(), 100000u);
  }
  const double w_ref = norm(ref.bodies().angular_velocity_rad_s[index_of(ref, 0)]);
  const double w_run = norm(run.bodies().angular_velocity_rad_s[index_of(run, 0)]);
  report("spin after the impact with a body added mid-contact", w_run, w_ref);
  EXPECT_GT(w_ref, 10.0);
  EXPECT_NEAR(w_run, w_ref, 1e-6 * w_ref);
}
