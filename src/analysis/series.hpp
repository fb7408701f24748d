// A drum time series as plain arrays (SPEC 6, STYLE 8): one entry per sample, sampled at a fixed
// rate. It does not care whether it came from a simulation (`biodem run`) or a video
// (`biodem video`). Missing optional values are NaN; a column absent from the source is an empty
// vector.
#pragma once
#include <cstddef>
#include <vector>

namespace biodem::analysis {

struct Series {
  std::vector<double> time_s;
  std::vector<double> revolution;         // turns of the drum since the start of rotation
  std::vector<double> alpha_deg;          // centroid angle
  std::vector<double> surface_r2;         // optional: NaN where missing, empty if absent
  std::vector<double> surface_angle_deg;  // optional
  std::vector<double> kinetic_energy_j;   // optional
  std::vector<double> contacts;           // optional (integer counts stored as double)

  std::size_t size() const { return time_s.size(); }
};

}  // namespace biodem::analysis
