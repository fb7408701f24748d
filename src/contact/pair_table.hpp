// Per-pair contact parameters (SPEC 2.1): effective moduli from the two materials and the
// pair's restitution, friction, rolling friction and cohesion, precomputed once at set-up into a
// dense symmetric table indexed by material.
#pragma once
#include <cstddef>
#include <vector>

namespace biodem::contact {

struct PairParams {
  double y_eff_pa = 0.0;
  double g_eff_pa = 0.0;
  double beta = 0.0;  // from restitution
  double friction = 0.0;
  double rolling_friction = 0.0;
  double cohesion_energy_density_j_m3 = 0.0;
  bool defined = false;
  // Which normal force bounds the Coulomb and EPSD2 limits (SPEC 2.2). false (the reference,
  // LIGGGHTS 3.8.0 `tangential_reduce off`): Hertz + damping, cohesion not subtracted. true
  // (`tangential_reduce on`): Hertz + damping - cohesion. Set for every pair from
  // [contact] tangential_reduce.
  bool tangential_reduce = false;
};

class PairTable {
 public:
  PairTable() = default;
  explicit PairTable(std::size_t n_materials) : n_(n_materials), table_(n_materials * n_materials) {}
  void set(std::size_t a, std::size_t b, const PairParams& p) {
    table_[a * n_ + b] = p;
    table_[b * n_ + a] = p;
  }
  const PairParams& operator()(std::size_t a, std::size_t b) const { return table_[a * n_ + b]; }
  std::size_t materials() const { return n_; }
  bool any_cohesion() const {
    for (const auto& p : table_) if (p.defined && p.cohesion_energy_density_j_m3 > 0.0) return true;
    return false;
  }
  bool any_rolling() const {
    for (const auto& p : table_) if (p.defined && p.rolling_friction > 0.0) return true;
    return false;
  }

 private:
  std::size_t n_ = 0;
  std::vector<PairParams> table_;
};

}  // namespace biodem::contact
