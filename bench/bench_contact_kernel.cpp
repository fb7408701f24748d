// Micro-benchmarks of the per-contact kernel (Google Benchmark): nanoseconds per evaluation of
// the composed contact model, without and with cohesion and rolling friction, and per torque-free
// rotation step of a clump. The drum-level
// benchmark against LIGGGHTS is bench/run_bench.sh.
#include <benchmark/benchmark.h>

#include <random>
#include <vector>

#include "contact/contact_model.hpp"
#include "integrate/rigid_rotation.hpp"

using namespace biodem;

namespace {
template <bool C, bool R>
void BM_Contact(benchmark::State& st) {
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const std::size_t n = 4096;
  std::vector<contact::ContactGeometry> g(n);
  std::vector<contact::ContactHistory> h(n);
  for (auto& x : g) {
    x.normal = normalized(Vec3{u(rng), u(rng), u(rng)});
    x.overlap_m = 1e-6 * (1.5 + u(rng));
    x.r_eff_m = 2.5e-4;
    x.m_eff_kg = 6.7e-7;
    x.lever_i = -0.5e-3 * x.normal;
    x.lever_j = 0.5e-3 * x.normal;
    x.v_rel = Vec3{u(rng), u(rng), u(rng)} * 1e-2;
    x.w_rel = Vec3{u(rng), u(rng), u(rng)};
  }
  contact::PairParams p{2.6e6, 1.0e6, -0.5, 0.3, 0.3, 5e4, true};
  for (auto _ : st) {
    for (std::size_t k = 0; k < n; ++k) {
      auto out = contact::evaluate_contact<C, R>(g[k], p, h[k], 1e-9, 1e-5);
      benchmark::DoNotOptimize(out);
    }
  }
  st.SetItemsProcessed(static_cast<std::int64_t>(st.iterations() * n));
}

// One torque-free rotation step of a clump (the drift of every needle, every step).
void BM_FreeRotation(benchmark::State& st) {
  std::mt19937_64 rng(2);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const std::size_t n = 4096;
  std::vector<Quat> q(n);
  std::vector<Vec3> l(n);
  for (std::size_t k = 0; k < n; ++k) {
    q[k] = normalized(Quat{u(rng), u(rng), u(rng), u(rng)});
    l[k] = Vec3{u(rng), u(rng), u(rng)} * 1e-9;
  }
  const Vec3 inertia{2.1e-12, 2.1e-12, 0.4e-12};
  for (auto _ : st) {
    for (std::size_t k = 0; k < n; ++k) {
      Vec3 w = integrate::free_rotation_step(q[k], l[k], inertia, 1e-5);
      benchmark::DoNotOptimize(w);
    }
  }
  st.SetItemsProcessed(static_cast<std::int64_t>(st.iterations() * n));
}
}  // namespace

BENCHMARK(BM_FreeRotation)->Name("integrate/free_rotation_step");
BENCHMARK(BM_Contact<false, false>)->Name("contact/hertz_mindlin");
BENCHMARK(BM_Contact<true, true>)->Name("contact/hertz_mindlin_sjkr_epsd2");
BENCHMARK_MAIN();
