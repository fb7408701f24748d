#include "scenario/bulk_measures.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace biodem::scenario {

HeapResult measure_heap(const std::vector<Vec3>& c, const std::vector<double>& r, const Vec3& origin, const Vec3& up,
                        double bin_m, double fit_from, double fit_to) {
  HeapResult out;
  if (c.empty() || !(bin_m > 0.0)) return out;
  std::vector<double> top;  // highest sphere top per radial bin; -inf where empty
  for (std::size_t i = 0; i < c.size(); ++i) {
    const Vec3 d = c[i] - origin;
    const double h = dot(d, up) + r[i];
    const double rho = norm(d - dot(d, up) * up);
    const std::size_t b = static_cast<std::size_t>(rho / bin_m);
    if (b >= top.size()) top.resize(b + 1, -INFINITY);
    top[b] = std::max(top[b], h);
    out.height_m = std::max(out.height_m, h);
  }
  std::size_t outer = top.size();
  for (std::size_t b = top.size(); b-- > 0;)
    if (top[b] >= 2.0 * bin_m) {
      outer = b;
      break;
    }
  if (outer == top.size()) return out;  // no heap: nothing two particle sizes high
  out.base_radius_m = (static_cast<double>(outer) + 1.0) * bin_m;
  double sx = 0, sy = 0, sxx = 0, sxy = 0, n = 0;
  for (std::size_t b = 0; b <= outer; ++b) {
    const double rho = (static_cast<double>(b) + 0.5) * bin_m;
    if (!std::isfinite(top[b]) || rho < fit_from * out.base_radius_m || rho > fit_to * out.base_radius_m) continue;
    sx += rho;
    sy += top[b];
    sxx += rho * rho;
    sxy += rho * top[b];
    n += 1;
  }
  out.bins_fitted = static_cast<std::size_t>(n);
  if (n < 2) return out;
  const double slope = (n * sxy - sx * sy) / (n * sxx - sx * sx);
  out.angle_deg = std::atan(-slope) * 180.0 / std::numbers::pi;
  out.valid = true;
  return out;
}

}  // namespace biodem::scenario
