// A contact that opens loses its history (SPEC 2.2, as LIGGGHTS 3.8.0: the tangential spring xi
// and the EPSD2 rolling torque m_r start from zero at every new touch). Oblique, spinning
// impacts, a sphere on a plane and a sphere on a resting sphere, with a skin so large that the
// list is not rebuilt between the touch and the separation (a rebuild would drop the entry and
// hide a history left behind): during the contact the history is non-zero; once the spheres
// part, the entry (wall slot) is still in the list, not touching, with a zero history, on the
// scalar path and on the widest SIMD kernel of this CPU. Tolerance: none (exact zeros).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <string>

#include "physics_support.hpp"
#include "sim/pair_pass.hpp"

using namespace biodem;
using namespace biodem::phys;

namespace {

constexpr double kR = 1.0e-3;
const Material kBead{5e7, 0.3, 2500.0};
const Material kPlate{5e7, 0.3, 0.0};

sim::Simulation scene(sim::PairKernel kernel) {
  SimSetup su;
  su.particle = kBead;
  su.wall = kPlate;
  su.particle_particle = {0.5, 0.5, 0.3, 2e4};  // restitution, sliding, rolling friction, cohesion
  su.particle_wall = {0.5, 0.5, 0.3, 2e4};
  su.templates = {sphere_template(kR)};
  su.dt_s = 2e-7;
  sim::Simulation s = make_simulation(su);
  s.set_pair_kernel(kernel);
  s.set_skin(4.0 * kR);
  return s;
}

bool zero(const contact::ContactHistory& h) { return h.xi == Vec3{} && h.m_r == Vec3{}; }
bool nonzero(const contact::ContactHistory& h) { return !(h.xi == Vec3{}) && !(h.m_r == Vec3{}); }

std::vector<sim::PairKernel> kernels() {
  std::vector<sim::PairKernel> k{sim::PairKernel::Scalar};
  if (sim::best_pair_kernel() != sim::PairKernel::Scalar) k.push_back(sim::best_pair_kernel());
  return k;
}

}  // namespace

TEST(ContactRelease, WallContactThatOpensLosesItsHistory) {
  const ScopedThreads one_thread(1);
  for (const sim::PairKernel kernel : kernels()) {
    SCOPED_TRACE(sim::pair_kernel_name(kernel));
    sim::Simulation s = scene(kernel);
    s.add_wall(plane_wall({0, 0, 0}, {0, 0, 1}));
    // 0.5 m/s at 45 degrees, spinning about x and y: sliding and rolling springs both load.
    add_particle(s, 0, {0, 0, kR + 1e-6}, {0.35, 0, -0.35}, {300.0, -200.0, 0.0});
    s.step();  // the first list build
    const std::uint64_t builds = s.neighbor_list().builds();
    bool loaded = false, parted = false;
    for (int k = 0; k < 20000 && !parted; ++k) {
      s.step();
      const auto& wc = s.wall_contacts();
      ASSERT_EQ(wc.history.size(), 1u) << "the plate's slot is kept (skin 4R)";
      if (wc.touching[0]) loaded |= nonzero(wc.history[0]);
      else if (loaded) parted = true;
    }
    ASSERT_TRUE(loaded) << "the contact never loaded both springs";
    ASSERT_TRUE(parted) << "the sphere did not leave the plate";
    EXPECT_EQ(s.neighbor_list().builds(), builds) << "a list build between touch and separation";
    EXPECT_TRUE(zero(s.wall_contacts().history[0])) << "history left behind by a wall contact that opened";
  }
}

TEST(ContactRelease, PairContactThatOpensLosesItsHistory) {
  const ScopedThreads one_thread(1);
  for (const sim::PairKernel kernel : kernels()) {
    SCOPED_TRACE(sim::pair_kernel_name(kernel));
    sim::Simulation s = scene(kernel);
    // A resting sphere and one arriving at 0.5 m/s along x, offset by R in y, spinning.
    add_particle(s, 0, {0, 0, 0}, {0, 0, 0});
    add_particle(s, 0, {-2.0 * kR - 1e-6, kR, 0}, {0.5, 0, 0}, {0.0, 0.0, 400.0});
    s.step();  // the first list build
    const std::uint64_t builds = s.neighbor_list().builds();
    const auto& L = s.neighbor_list();
    bool loaded = false, parted = false;
    for (int k = 0; k < 20000 && !parted; ++k) {
      s.step();
      ASSERT_EQ(L.j.size(), 1u) << "the pair's entry is kept (skin 4R)";
      if (L.touching[0]) loaded |= nonzero(L.history[0]);
      else if (loaded) parted = true;
    }
    ASSERT_TRUE(loaded) << "the contact never loaded both springs";
    ASSERT_TRUE(parted) << "the spheres did not part";
    EXPECT_EQ(L.builds(), builds) << "a list build between touch and separation";
    EXPECT_TRUE(zero(L.history[0])) << "history left behind by a pair contact that opened";
  }
}
