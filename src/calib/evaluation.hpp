// One evaluation of a campaign: a decision vector, what its bulk tests measured and its two
// objectives.
#pragma once
#include <cstdint>
#include <vector>

namespace biodem::calib {

struct Evaluation {
  std::uint64_t generation = 0, index = 0;  // batch (0: initial population) and position in it
  std::vector<double> x;                    // decision vector (parameters)
  std::vector<double> responses;            // what the evaluator measured (any length)
  double o1 = 0.0, o2 = 0.0;                // objectives, both minimised
  double wall_s = 0.0;
};

}  // namespace biodem::calib
