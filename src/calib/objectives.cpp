#include "calib/objectives.hpp"

#include <algorithm>
#include <cmath>

namespace biodem::calib {

std::vector<std::string> response_names(const CalibConfig& c) {
  std::vector<std::string> r;
  for (const auto* o : {&c.o1, &c.o2})
    for (const auto& n : o->responses)
      if (std::find(r.begin(), r.end(), n) == r.end()) r.push_back(n);
  return r;
}

double objective(const CalibConfig& c, const CalibObjective& o, const std::map<std::string, double>& measured) {
  double s = 0.0, w = 0.0;
  for (std::size_t k = 0; k < o.responses.size(); ++k) {
    const auto it = measured.find(o.responses[k]);
    const double t = target_of(c, o.responses[k]).value;
    const double v = it == measured.end() ? NAN : it->second;
    s += o.weights[k] * std::abs(v - t) / std::abs(t);
    w += o.weights[k];
  }
  return w > 0.0 ? s / w : 0.0;
}

}  // namespace biodem::calib
