// From a validated case (config structs) to a ready Simulation: templates (coarse-grained),
// pair table, walls, drum, explicit particles. No insertion (that happens while running).
#pragma once
#include <memory>
#include <optional>
#include <vector>

#include "config/case_config.hpp"
#include "scenario/drum.hpp"
#include "scenario/insertion.hpp"
#include "sim/simulation.hpp"

namespace biodem::driver {

struct BuiltCase {
  std::unique_ptr<sim::Simulation> sim;
  std::optional<scenario::DrumGeometry> drum;
  double coarse_grain = 1.0;
  std::vector<scenario::InsertionRequest> populations;  // one per [[population]]
  std::vector<double> population_volume_fraction;
  std::vector<double> population_particle_volume_m3;
};

contact::PairTable make_pair_table(const config::CaseConfig& c);
BuiltCase build_simulation(const config::CaseConfig& c);

}  // namespace biodem::driver
