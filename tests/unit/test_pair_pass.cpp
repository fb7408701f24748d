// The SIMD pair pass against the scalar reference (src/sim/pair_pass.hpp): for every kernel this
// machine runs (2, 4, 8 lanes), the per-sphere sums, the stored pair results, the histories and
// the touching flags after 40 passes equal the scalar pass's bit for bit (tolerance: zero; every
// lane does the scalar law's correctly rounded operations in the same order, and no file of the
// pass is compiled with fused multiply-add contraction). Scenes: polydisperse spheres of two
// materials with different friction and rolling friction, each combination of cohesion and
// rolling, both friction-limit rules, and a periodic axis.
#include <gtest/gtest.h>

#include <cstring>
#include <random>
#include <vector>

#include "contact/contact_model.hpp"
#include "neighbor/verlet_list.hpp"
#include "sim/pair_pass.hpp"
#include "state/particle_store.hpp"

using namespace biodem;

namespace {

struct Scene {
  state::SphereStore s;
  contact::PairTable pairs{2};
  neighbor::VerletList list;
};

// A loose jittered lattice of spheres 0.8-1.2 mm across, about 40 % of the list entries touching,
// random velocities (some pairs slide, some stick) and spins.
Scene make_scene(bool cohesion, bool rolling, bool reduce, bool periodic) {
  Scene sc;
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const int m = 9;
  const double a = 1.0e-3;
  for (int x = 0; x < m; ++x)
    for (int y = 0; y < m; ++y)
      for (int z = 0; z < m; ++z) {
        const double r = 0.5e-3 * (1.0 + 0.2 * u(rng));
        sc.s.position_m.push_back(Vec3{x * a, y * a, (z + 0.5) * a} + 0.06e-3 * Vec3{u(rng), u(rng), u(rng)});
        sc.s.velocity_m_s.push_back(2e-2 * Vec3{u(rng), u(rng), u(rng)});
        sc.s.angular_velocity_rad_s.push_back(20.0 * Vec3{u(rng), u(rng), u(rng)});
        sc.s.radius_m.push_back(r);
        sc.s.offset_body_m.push_back({});
        sc.s.body.push_back(static_cast<std::uint32_t>(sc.s.body.size()));
        sc.s.material.push_back(static_cast<std::uint16_t>((x + y + z) % 2));
        sc.s.body_mass_kg.push_back(2550.0 * 4.18879 * r * r * r);
      }
  sc.s.force_n.resize(sc.s.size());
  sc.s.torque_n_m.resize(sc.s.size());
  auto params = [&](double friction, double rolling_friction) {
    contact::PairParams p;
    p.y_eff_pa = 2.6e6;
    p.g_eff_pa = 1.07e6;
    p.beta = contact::damping_beta(0.6);
    p.friction = friction;
    p.rolling_friction = rolling ? rolling_friction : 0.0;
    p.cohesion_energy_density_j_m3 = cohesion ? 2e5 : 0.0;
    p.defined = true;
    p.tangential_reduce = reduce;
    return p;
  };
  sc.pairs.set(0, 0, params(0.3, 0.2));
  sc.pairs.set(0, 1, params(0.5, 0.05));
  sc.pairs.set(1, 1, params(0.1, 0.6));
  neighbor::Domain dom;
  if (periodic) {
    dom.periodic = {false, false, true};
    dom.lo_m = {0, 0, 0};
    dom.hi_m = {0, 0, m * a};
  }
  sc.list.configure(dom, 0.25e-3);
  sc.list.build(sc.s);
  return sc;
}

sim::PairPassData view(Scene& sc, bool periodic) {
  return sim::make_pair_pass_data(sc.s, sc.list, sc.pairs, 1e-5, periodic);
}

// Runs 40 passes; between passes the spheres move a little (so contacts open and close).
template <bool C, bool R>
Scene run(sim::PairKernel kernel, bool reduce, bool periodic, std::size_t& contacts) {
  Scene sc = make_scene(C, R, reduce, periodic);
  const sim::PairPassData d = view(sc, periodic);
  contacts = 0;
  for (int pass = 0; pass < 40; ++pass) {
    contacts += sim::pair_rows<C, R>(kernel, d, 0, sc.s.size() / 3);  // two calls: a batch ends mid-way
    contacts += sim::pair_rows<C, R>(kernel, d, sc.s.size() / 3, sc.s.size());
    for (std::size_t i = 0; i < sc.s.size(); ++i) sc.s.position_m[i] += 1e-5 * sc.s.velocity_m_s[i];
  }
  return sc;
}

bool same_bits(const void* a, const void* b, std::size_t bytes) { return std::memcmp(a, b, bytes) == 0; }

template <bool C, bool R>
void expect_kernels_equal_scalar(bool reduce, bool periodic) {
  std::size_t ref_contacts = 0;
  const Scene ref = run<C, R>(sim::PairKernel::Scalar, reduce, periodic, ref_contacts);
  const std::size_t n = ref.s.size(), e = ref.list.entries();
  std::size_t touching = 0;
  for (auto t : ref.list.touching) touching += t;
  ASSERT_GT(touching, e / 5) << "the scene should keep many contacts";
  ASSERT_LT(touching, e) << "and some entries apart";
  std::size_t compared = 0;
  for (sim::PairKernel k : {sim::PairKernel::Lanes2, sim::PairKernel::Lanes4, sim::PairKernel::Lanes8}) {
    if (!sim::pair_kernel_available(k)) continue;
    ++compared;
    SCOPED_TRACE(sim::pair_kernel_name(k));
    std::size_t contacts = 0;
    const Scene got = run<C, R>(k, reduce, periodic, contacts);
    EXPECT_EQ(contacts, ref_contacts);
    EXPECT_TRUE(same_bits(got.s.force_n.data(), ref.s.force_n.data(), n * sizeof(Vec3)));
    EXPECT_TRUE(same_bits(got.s.torque_n_m.data(), ref.s.torque_n_m.data(), n * sizeof(Vec3)));
    EXPECT_TRUE(same_bits(got.list.force_i.data(), ref.list.force_i.data(), e * sizeof(Vec3)));
    EXPECT_TRUE(same_bits(got.list.torque_j.data(), ref.list.torque_j.data(), e * sizeof(Vec3)));
    EXPECT_TRUE(same_bits(got.list.history.data(), ref.list.history.data(), e * sizeof(contact::ContactHistory)));
    EXPECT_EQ(got.list.touching, ref.list.touching);
  }
  EXPECT_GE(compared, 1u) << "no lanes kernel in this build: nothing was compared";
}

}  // namespace

TEST(PairPass, LanesEqualScalarHertzMindlin) { expect_kernels_equal_scalar<false, false>(false, false); }
TEST(PairPass, LanesEqualScalarWithRolling) { expect_kernels_equal_scalar<false, true>(false, false); }
TEST(PairPass, LanesEqualScalarWithCohesion) { expect_kernels_equal_scalar<true, false>(false, false); }
TEST(PairPass, LanesEqualScalarCohesionRollingBothLimitRules) {
  expect_kernels_equal_scalar<true, true>(false, false);
  expect_kernels_equal_scalar<true, true>(true, false);
}
TEST(PairPass, LanesEqualScalarAcrossAPeriodicAxis) { expect_kernels_equal_scalar<true, true>(false, true); }

TEST(PairPass, BestKernelIsAvailableAndNamed) {
  if (!sim::pair_kernel_available(sim::PairKernel::Lanes2)) GTEST_SKIP() << "built without <experimental/simd>";
  const sim::PairKernel k = sim::best_pair_kernel();
  EXPECT_TRUE(sim::pair_kernel_available(k));
  EXPECT_NE(k, sim::PairKernel::Scalar);
  EXPECT_FALSE(sim::pair_kernel_name(k).empty());
  EXPECT_TRUE(sim::pair_kernel_available(sim::PairKernel::Scalar));
  EXPECT_TRUE(sim::pair_kernel_available(sim::PairKernel::Lanes2));
}
