// Micro-benchmark of the CPU pair pass (src/sim/pair_pass.hpp): nanoseconds per neighbour-list
// entry of a jittered cubic packing of 4,913 glass beads (1 mm, about half the entries touching,
// as in a resting drum bed), for each kernel this machine runs (scalar, 2, 4, 8 lanes), without
// and with cohesion and rolling friction. The same rows and history for every kernel, so the
// kernels can be compared in one process, interleaved.
#include <benchmark/benchmark.h>

#include <random>
#include <vector>

#include "contact/pair_table.hpp"
#include "neighbor/verlet_list.hpp"
#include "sim/pair_pass.hpp"
#include "state/particle_store.hpp"

using namespace biodem;

namespace {

struct Bed {
  state::SphereStore s;
  contact::PairTable pairs{1};
  neighbor::VerletList list;
  std::size_t touching = 0;
};

Bed make_bed(bool cohesion, bool rolling) {
  Bed b;
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const int m = 17;
  const double a = 1.0e-3, r = 0.5e-3, jitter = 0.05e-3;
  for (int x = 0; x < m; ++x)
    for (int y = 0; y < m; ++y)
      for (int z = 0; z < m; ++z) {
        b.s.position_m.push_back(Vec3{x * a, y * a, z * a} + jitter * Vec3{u(rng), u(rng), u(rng)});
        b.s.velocity_m_s.push_back(1e-2 * Vec3{u(rng), u(rng), u(rng)});
        b.s.angular_velocity_rad_s.push_back(Vec3{u(rng), u(rng), u(rng)});
        b.s.radius_m.push_back(r);
        b.s.offset_body_m.push_back({});
        b.s.body.push_back(static_cast<std::uint32_t>(b.s.body.size()));
        b.s.material.push_back(0);
        b.s.body_mass_kg.push_back(1.335e-6);
      }
  b.s.force_n.resize(b.s.size());
  b.s.torque_n_m.resize(b.s.size());
  contact::PairParams p{2.6e6, 1.0e6, -0.044, 0.2, rolling ? 0.3 : 0.0, cohesion ? 5e4 : 0.0, true, false};
  b.pairs.set(0, 0, p);
  b.list.configure(neighbor::Domain{}, 0.25e-3);
  b.list.build(b.s);
  return b;
}

sim::PairPassData view(Bed& b) { return sim::make_pair_pass_data(b.s, b.list, b.pairs, 1.5e-5, false); }

template <bool C, bool R>
void BM_PairPass(benchmark::State& st) {
  const auto kernel = static_cast<sim::PairKernel>(st.range(0));
  if (!sim::pair_kernel_available(kernel)) {
    st.SkipWithError("kernel not available on this CPU");
    return;
  }
  Bed b = make_bed(C, R);
  const sim::PairPassData d = view(b);
  std::size_t contacts = 0;
  for (auto _ : st) contacts = sim::pair_rows<C, R>(kernel, d, 0, b.s.size());
  st.SetItemsProcessed(static_cast<std::int64_t>(st.iterations() * b.list.entries()));
  st.counters["touching"] = static_cast<double>(contacts) / static_cast<double>(b.list.entries());
  st.SetLabel(sim::pair_kernel_name(kernel));
}

}  // namespace

BENCHMARK(BM_PairPass<false, false>)->Name("pair_pass/hertz_mindlin")->Arg(1)->Arg(2)->Arg(4)->Arg(8);
BENCHMARK(BM_PairPass<true, true>)->Name("pair_pass/hertz_mindlin_sjkr_epsd2")->Arg(1)->Arg(2)->Arg(4)->Arg(8);
