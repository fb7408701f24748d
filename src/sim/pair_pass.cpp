#include "sim/pair_pass.hpp"

#include <cmath>
#include <cstdlib>
#include <string_view>

#include "contact/contact_model.hpp"
#include "core/error.hpp"

namespace biodem::sim {
namespace {

/// A row entry whose spheres no longer touch: its history and stored results are cleared.
inline void release_entry(neighbor::VerletList& L, std::uint32_t k) {
  if (L.touching[k]) {
    L.touching[k] = 0;
    L.history[k] = {};
    L.force_i[k] = {};
    L.torque_j[k] = {};
  }
}

template <bool Cohesion, bool Rolling>
std::size_t rows_scalar(const PairPassData& d, std::size_t i0, std::size_t i1) {
  auto& L = *d.list;
  const double dt = d.dt_s;
  std::size_t contacts = 0;
  for (std::size_t i = i0; i < i1; ++i) {
    const Vec3 xi = d.position_m[i];
    const double ri = d.radius_m[i];
    Vec3 f_own, t_own;
    for (std::uint32_t k = L.row_start[i]; k < L.row_start[i + 1]; ++k) {
      const std::uint32_t j = L.j[k];
      Vec3 dij = xi - d.position_m[j];
      if (d.periodic) dij -= L.shift(k);
      const double rj = d.radius_m[j];
      const double dist2 = norm2(dij), rsum = ri + rj;
      if (dist2 >= rsum * rsum) {
        release_entry(L, k);
        continue;
      }
      const double dist = std::sqrt(dist2);
      const contact::ContactGeometry g = contact::sphere_sphere_geometry(
          dij, dist, ri, rj, d.body_mass_kg[i], d.body_mass_kg[j], d.velocity_m_s[i], d.velocity_m_s[j],
          d.angular_velocity_rad_s[i], d.angular_velocity_rad_s[j]);
      const contact::PairParams& p = (*d.pairs)(d.material[i], d.material[j]);
      const double area = Cohesion ? contact::sjkr_area_sphere_sphere(ri, rj, dist) : 0.0;
      const contact::ContactOutput out = contact::evaluate_contact<Cohesion, Rolling>(g, p, L.history[k], area, dt);
      L.touching[k] = 1;
      L.force_i[k] = out.force_i;
      L.torque_j[k] = out.torque_j;
      f_own += out.force_i;
      t_own += out.torque_i;
      ++contacts;
    }
    d.force_n[i] = f_own;
    d.torque_n_m[i] = t_own;
  }
  return contacts;
}

/// The lane kernel: stage touching contacts, evaluate a full batch in lanes, scatter in order.
template <bool Cohesion, bool Rolling>
class LaneRows {
 public:
  using Evaluate = void (*)(PairBatch&);
  LaneRows(const PairPassData& d, Evaluate evaluate) : d_(d), evaluate_(evaluate) { b_.data = &d; }

  std::size_t run(std::size_t i0, std::size_t i1) {
    return d_.periodic ? stage_rows<true>(i0, i1) : stage_rows<false>(i0, i1);
  }

 private:
  template <bool Periodic>
  std::size_t stage_rows(std::size_t i0, std::size_t i1) {
    // What the staging loop reads is held in locals, and it stores no bytes (which may alias
    // anything and would make the compiler reload): contacts that ended are noted in `ended_`
    // and released after the loop or when the note is full. The batch's arrays are addressed
    // from this object (one register for all of them, none spilled).
    auto& L = *d_.list;
    const std::uint32_t* const jv = L.j.data();
    const std::uint32_t* const row_of = L.row_of.data();
    const std::uint8_t* const was_touching = L.touching.data();
    const Vec3* const pos = d_.position_m;
    const double* const rad = d_.radius_m;
    const auto* const mat = d_.material;
    const contact::PairParams* const table = &(*d_.pairs)(0, 0);
    const std::size_t n_materials = d_.pairs->materials();
    using F = PairBatch;
    for (std::size_t i = i0; i < i1; ++i) {  // the scatter adds each row's contacts in entry order
      d_.force_n[i] = {};
      d_.torque_n_m[i] = {};
    }
    staged_ = 0;
    int n = 0, n_ended = 0;
    // One flat loop over the rows' entries, i read from row_of: rows are short (3-6 entries in a
    // bed with the default skin), and a loop per row mispredicted its exit once per row.
    const std::uint32_t k1 = L.row_start[i1];
    for (std::uint32_t k = L.row_start[i0]; k < k1; ++k) {
      const std::uint32_t i = row_of[k], j = jv[k];
      Vec3 dij = pos[i] - pos[j];
      if constexpr (Periodic) dij -= L.shift(k);
      const double rsum = rad[i] + rad[j];
      const double dist2 = norm2(dij);
      // Without a branch on the distance test (about half the entries touch, so it would be
      // mispredicted often): every entry is written to the next slot, which only a touching
      // entry keeps; likewise every entry to the next slot of `ended_`.
      const bool touch = dist2 < rsum * rsum;
      b_.a[F::Dx][n] = dij.x;
      b_.a[F::Dy][n] = dij.y;
      b_.a[F::Dz][n] = dij.z;
      b_.a[F::Dist2][n] = dist2;
      b_.i[n] = i;
      b_.j[n] = j;
      b_.k[n] = k;
      b_.params[n] = table + mat[i] * n_materials + mat[j];
      n += touch;
      ended_[n_ended] = k;
      n_ended += static_cast<int>(static_cast<bool>(was_touching[k]) & !touch);
      if (n == PairBatch::kCapacity) {
        b_.n = n;
        flush();
        n = 0;
      }
      if (n_ended == kEnded) {
        release(n_ended);
        n_ended = 0;
      }
    }
    b_.n = n;
    flush();
    release(n_ended);
    return staged_;
  }

  /// The entries noted in `ended`: contacts that ended this step (their history and stored
  /// results are cleared).
  void release(int n_ended) {
    for (int e = 0; e < n_ended; ++e) release_entry(*d_.list, ended_[e]);
  }


  void flush() {
    const int n = b_.n;
    if (n == 0) return;
    staged_ += static_cast<std::size_t>(n);
    // Pad to a multiple of the widest lane count with copies of the last contact (results unused).
    for (int s = n; s % 8 != 0; ++s) {
      for (int f = PairBatch::Dx; f <= PairBatch::Dist2; ++f) b_.a[f][s] = b_.a[f][n - 1];
      b_.i[s] = b_.i[n - 1];
      b_.j[s] = b_.j[n - 1];
      b_.k[s] = b_.k[n - 1];
      b_.params[s] = b_.params[n - 1];
    }
    evaluate_(b_);
    using F = PairBatch;
    auto& L = *d_.list;
    std::uint8_t* const touching = L.touching.data();
    Vec3* const force_i = L.force_i.data();
    Vec3* const torque_j = L.torque_j.data();
    contact::ContactHistory* const history = L.history.data();
    // Row i's sums are kept in registers while its contacts follow one another (the same
    // additions in the same order as adding to force_n[i] in memory, without a store-to-load
    // chain per contact); a row continued from the previous batch starts from its stored sum.
    std::uint32_t row = b_.i[0];
    Vec3 f_row = d_.force_n[row], t_row = d_.torque_n_m[row];
    for (int s = 0; s < n; ++s) {
      auto get3 = [&](int f) { return Vec3{b_.a[f][s], b_.a[f + 1][s], b_.a[f + 2][s]}; };
      const std::uint32_t k = b_.k[s], i = b_.i[s];
      if (i != row) {
        d_.force_n[row] = f_row;
        d_.torque_n_m[row] = t_row;
        row = i;
        f_row = d_.force_n[i];
        t_row = d_.torque_n_m[i];
      }
      const Vec3 f_i = get3(F::Fx);
      touching[k] = 1;
      force_i[k] = f_i;
      torque_j[k] = get3(F::Tjx);
      history[k].xi = get3(F::Xix);
      if constexpr (Rolling) history[k].m_r = get3(F::Mrx);
      f_row += f_i;
      t_row += get3(F::Tix);
    }
    d_.force_n[row] = f_row;
    d_.torque_n_m[row] = t_row;
    b_.n = 0;
  }

  static constexpr int kEnded = 64;
  const PairPassData& d_;
  Evaluate evaluate_;
  PairBatch b_;
  std::uint32_t ended_[kEnded];
  std::size_t staged_ = 0;  // touching contacts of this call
};

bool cpu_has(PairKernel k) {
#if !defined(BIODEM_SIMD_LANES)
  return k == PairKernel::Scalar;  // built without <experimental/simd>
#elif defined(BIODEM_X86_LANES)
  if (k == PairKernel::Lanes4) return __builtin_cpu_supports("avx2");
  if (k == PairKernel::Lanes8) return __builtin_cpu_supports("avx512f");
  return true;
#else
  return k == PairKernel::Scalar || k == PairKernel::Lanes2;
#endif
}

}  // namespace

bool pair_kernel_available(PairKernel k) { return cpu_has(k); }

PairPassData make_pair_pass_data(state::SphereStore& s, neighbor::VerletList& list, const contact::PairTable& pairs,
                                 double dt_s, bool periodic) {
  PairPassData d;
  d.position_m = s.position_m.data();
  d.velocity_m_s = s.velocity_m_s.data();
  d.angular_velocity_rad_s = s.angular_velocity_rad_s.data();
  d.radius_m = s.radius_m.data();
  d.body_mass_kg = s.body_mass_kg.data();
  d.material = s.material.data();
  d.pairs = &pairs;
  d.list = &list;
  d.force_n = s.force_n.data();
  d.torque_n_m = s.torque_n_m.data();
  d.dt_s = dt_s;
  d.periodic = periodic;
  return d;
}

PairKernel best_pair_kernel() {
  for (PairKernel k : {PairKernel::Lanes8, PairKernel::Lanes4, PairKernel::Lanes2})
    if (cpu_has(k)) return k;
  return PairKernel::Scalar;
}

std::string pair_kernel_name(PairKernel k) {
  switch (k) {
    case PairKernel::Scalar: return "scalar";
    case PairKernel::Lanes2: return "2 lanes (SSE2)";
    case PairKernel::Lanes4: return "4 lanes (AVX2)";
    case PairKernel::Lanes8: return "8 lanes (AVX-512F)";
  }
  return "?";
}

PairKernel pair_kernel_from_environment() {
  const char* v = std::getenv("BIODEM_PAIR_KERNEL");
  if (v == nullptr || *v == '\0') return best_pair_kernel();
  const std::string_view s(v);
  PairKernel k;
  if (s == "scalar") k = PairKernel::Scalar;
  else if (s == "2") k = PairKernel::Lanes2;
  else if (s == "4") k = PairKernel::Lanes4;
  else if (s == "8") k = PairKernel::Lanes8;
  else throw Error("BIODEM_PAIR_KERNEL = '" + std::string(s) + "': expected scalar, 2, 4 or 8");
  if (!cpu_has(k)) throw Error("BIODEM_PAIR_KERNEL = " + std::string(s) + ": " + pair_kernel_name(k) +
                               " is not available on this CPU or in this build");
  return k;
}

template <bool Cohesion, bool Rolling>
std::size_t pair_rows(PairKernel kernel, const PairPassData& d, std::size_t i0, std::size_t i1) {
  switch (kernel) {
    case PairKernel::Scalar: return rows_scalar<Cohesion, Rolling>(d, i0, i1);
#if defined(BIODEM_X86_LANES)
    case PairKernel::Lanes4: return LaneRows<Cohesion, Rolling>(d, &evaluate_batch_lanes4<Cohesion, Rolling>).run(i0, i1);
    case PairKernel::Lanes8: return LaneRows<Cohesion, Rolling>(d, &evaluate_batch_lanes8<Cohesion, Rolling>).run(i0, i1);
#endif
#if defined(BIODEM_SIMD_LANES)
    default: return LaneRows<Cohesion, Rolling>(d, &evaluate_batch_lanes2<Cohesion, Rolling>).run(i0, i1);
#else
    default: return rows_scalar<Cohesion, Rolling>(d, i0, i1);
#endif
  }
}

template <bool Cohesion, bool Rolling>
void (*wall_batch_evaluator(PairKernel kernel))(WallBatch&) {
  switch (kernel) {
#if defined(BIODEM_X86_LANES)
    case PairKernel::Lanes4: return &evaluate_wall_batch_lanes4<Cohesion, Rolling>;
    case PairKernel::Lanes8: return &evaluate_wall_batch_lanes8<Cohesion, Rolling>;
#endif
#if defined(BIODEM_SIMD_LANES)
    case PairKernel::Lanes2: return &evaluate_wall_batch_lanes2<Cohesion, Rolling>;
#endif
    default: return nullptr;
  }
}

template void (*wall_batch_evaluator<false, false>(PairKernel))(WallBatch&);
template void (*wall_batch_evaluator<false, true>(PairKernel))(WallBatch&);
template void (*wall_batch_evaluator<true, false>(PairKernel))(WallBatch&);
template void (*wall_batch_evaluator<true, true>(PairKernel))(WallBatch&);

template std::size_t pair_rows<false, false>(PairKernel, const PairPassData&, std::size_t, std::size_t);
template std::size_t pair_rows<false, true>(PairKernel, const PairPassData&, std::size_t, std::size_t);
template std::size_t pair_rows<true, false>(PairKernel, const PairPassData&, std::size_t, std::size_t);
template std::size_t pair_rows<true, true>(PairKernel, const PairPassData&, std::size_t, std::size_t);

}  // namespace biodem::sim
