#include "scenario/bulk_measures.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <numeric>
#include <unordered_map>

namespace biodem::scenario {
namespace {

struct UnionFind {
  std::vector<std::uint32_t> parent;
  explicit UnionFind(std::size_t n) : parent(n) { std::iota(parent.begin(), parent.end(), 0u); }
  std::uint32_t find(std::uint32_t a) {
    while (parent[a] != a) a = parent[a] = parent[parent[a]];
    return a;
  }
  void join(std::uint32_t a, std::uint32_t b) {
    a = find(a), b = find(b);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
  }
};

/// Least-squares slope of y against x; NaN with fewer than 3 points.
double fitted_slope(const std::vector<double>& x, const std::vector<double>& y) {
  const double n = static_cast<double>(x.size());
  if (x.size() < 3) return NAN;
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (std::size_t k = 0; k < x.size(); ++k) sx += x[k], sy += y[k], sxx += x[k] * x[k], sxy += x[k] * y[k];
  const double den = n * sxx - sx * sx;
  return den > 0.0 ? (n * sxy - sx * sy) / den : NAN;
}

}  // namespace

HeapResult measure_heap(const std::vector<Vec3>& c, const std::vector<double>& r,
                        const std::vector<std::uint32_t>& body_of_sphere, const Vec3& origin, const Vec3& up,
                        const HeapOptions& o) {
  HeapResult out;
  out.sector_angle_deg.assign(o.sectors, NAN);
  const std::size_t n = c.size();
  if (n == 0 || !(o.bin_m > 0.0) || o.sectors == 0) return out;

  // 1. Bodies joined by touching spheres (a hash grid of cell 2 r_max + gap).
  std::unordered_map<std::uint32_t, std::uint32_t> body_index;  // body id -> 0..nb-1
  std::vector<std::uint32_t> sb(n);
  for (std::size_t i = 0; i < n; ++i) sb[i] = body_index.try_emplace(body_of_sphere[i], body_index.size()).first->second;
  const std::size_t nb = body_index.size();
  double r_max = 0.0;
  for (double x : r) r_max = std::max(r_max, x);
  const double cell = 2.0 * r_max * (1.0 + o.contact_gap_fraction);
  auto key = [&](long i, long j, long k) {
    return (static_cast<std::uint64_t>(i & 0x1fffff) << 42) | (static_cast<std::uint64_t>(j & 0x1fffff) << 21) |
           static_cast<std::uint64_t>(k & 0x1fffff);
  };
  std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> grid;
  auto cell_of = [&](const Vec3& x, int a) { return static_cast<long>(std::floor(x[a] / cell)); };
  for (std::size_t i = 0; i < n; ++i) grid[key(cell_of(c[i], 0), cell_of(c[i], 1), cell_of(c[i], 2))].push_back(static_cast<std::uint32_t>(i));
  UnionFind uf(nb);
  for (std::size_t i = 0; i < n; ++i) {
    const long ci = cell_of(c[i], 0), cj = cell_of(c[i], 1), ck = cell_of(c[i], 2);
    for (long a = ci - 1; a <= ci + 1; ++a)
      for (long b = cj - 1; b <= cj + 1; ++b)
        for (long d = ck - 1; d <= ck + 1; ++d) {
          const auto it = grid.find(key(a, b, d));
          if (it == grid.end()) continue;
          for (std::uint32_t j : it->second) {
            if (j <= i || sb[j] == sb[i]) continue;
            const double reach = r[i] + r[j] + o.contact_gap_fraction * std::min(r[i], r[j]);
            if (norm2(c[j] - c[i]) < reach * reach) uf.join(sb[i], sb[j]);
          }
        }
  }
  // The heap: the largest cluster (in bodies) with a sphere on the plate.
  std::vector<std::size_t> size(nb, 0);
  std::vector<std::uint8_t> on_plate(nb, 0);
  for (std::size_t b = 0; b < nb; ++b) ++size[uf.find(static_cast<std::uint32_t>(b))];
  for (std::size_t i = 0; i < n; ++i)
    if (dot(c[i] - origin, up) - r[i] < o.contact_gap_fraction * r[i]) on_plate[uf.find(sb[i])] = 1;
  std::uint32_t heap = 0;
  std::size_t best = 0;
  for (std::uint32_t b = 0; b < nb; ++b)
    if (uf.find(b) == b && on_plate[b] && size[b] > best) best = size[b], heap = b;
  out.heap_bodies = best;
  out.stray_bodies = nb - best;
  // Bodies off the heap whose lowest point is more than a particle size above its top: nothing
  // on the plate holds them there (the lifted cylinder does, or they are still falling).
  std::vector<double> low(nb, INFINITY);
  for (std::size_t i = 0; i < n; ++i) low[sb[i]] = std::min(low[sb[i]], dot(c[i] - origin, up) - r[i]);
  auto count_lifted = [&] {
    for (std::uint32_t b = 0; b < nb; ++b)
      if ((best == 0 || uf.find(b) != heap) && low[b] > out.height_m + o.bin_m) ++out.lifted_bodies;
  };
  if (best == 0) {
    count_lifted();
    return out;
  }

  // 2. Height, and the base radius from the all-azimuth profile.
  Vec3 e1 = std::abs(up.x) < 0.9 ? Vec3{1, 0, 0} : Vec3{0, 1, 0};
  e1 = e1 - dot(e1, up) * up;
  e1 = e1 / norm(e1);
  const Vec3 e2 = cross(up, e1);
  struct Point {
    double rho, top, phi;
  };
  std::vector<Point> pts;
  for (std::size_t i = 0; i < n; ++i) {
    if (uf.find(sb[i]) != heap) continue;
    const Vec3 d = c[i] - origin;
    const double h = dot(d, up) + r[i];
    const double a = dot(d, e1), b = dot(d, e2);
    pts.push_back({std::hypot(a, b), h, std::atan2(b, a) + std::numbers::pi});
    out.height_m = std::max(out.height_m, h);
  }
  count_lifted();
  std::vector<double> top;
  for (const Point& p : pts) {
    const auto k = static_cast<std::size_t>(p.rho / o.bin_m);
    if (k >= top.size()) top.resize(k + 1, -INFINITY);
    top[k] = std::max(top[k], p.top);
  }
  std::size_t outer = top.size();
  for (std::size_t k = top.size(); k-- > 0;)
    if (top[k] >= 2.0 * o.bin_m) {
      outer = k;
      break;
    }
  if (outer == top.size()) return out;  // no heap: nothing two particle sizes high
  out.base_radius_m = (static_cast<double>(outer) + 1.0) * o.bin_m;

  // 3. One profile and one fit per sector.
  const std::size_t nbins = outer + 1;
  std::vector<std::vector<double>> sector_top(o.sectors, std::vector<double>(nbins, -INFINITY));
  const double width = 2.0 * std::numbers::pi / static_cast<double>(o.sectors);
  for (const Point& p : pts) {
    const auto k = static_cast<std::size_t>(p.rho / o.bin_m);
    if (k >= nbins) continue;
    const auto s = std::min(o.sectors - 1, static_cast<std::size_t>(p.phi / width));
    sector_top[s][k] = std::max(sector_top[s][k], p.top);
  }
  const double lo = o.fit_from * out.height_m, hi = o.fit_to * out.height_m;
  std::vector<double> fitted;
  for (std::size_t s = 0; s < o.sectors; ++s) {
    std::vector<double> x, y;
    for (std::size_t k = 0; k < nbins; ++k) {
      const double t = sector_top[s][k];
      if (std::isfinite(t) && t >= lo && t <= hi) {
        x.push_back((static_cast<double>(k) + 0.5) * o.bin_m);
        y.push_back(t);
      }
    }
    double slope = fitted_slope(x, y);
    // (only on a heap at least 4 bins high: the band's two levels then lie more than 2 bins
    // apart; on a lower bed the crossings are those of single particles, and a bump of a flat
    // bed would read as a steep flank)
    if (x.size() < 3 && out.height_m >= 4.0 * o.bin_m) {
      // A steep sector: the band (0.6 H high) spans fewer than 3 bins of its profile (at tan
      // theta above about 0.2 H / d). Its slope from where the profile crosses the band's two
      // levels, each radius interpolated between the bin centres around the crossing (before,
      // such a sector was not fitted, and a steep heap or a standing column scored 0 degrees).
      auto crossing = [&](double level) {  // outermost radius where the profile is still >= level
        for (std::size_t k = nbins; k-- > 0;) {
          const double t = sector_top[s][k];
          if (!(std::isfinite(t) && t >= level)) continue;
          const double next = k + 1 < nbins && std::isfinite(sector_top[s][k + 1]) ? sector_top[s][k + 1] : 0.0;
          const double f = t > next ? std::clamp((t - level) / (t - next), 0.0, 1.0) : 0.0;
          return (static_cast<double>(k) + 0.5 + f) * o.bin_m;
        }
        return std::nan("");
      };
      const double r_hi = crossing(hi), r_lo = crossing(lo);
      slope = r_lo > r_hi ? -(hi - lo) / (r_lo - r_hi) : std::nan("");
      if (std::isfinite(slope)) ++out.sectors_steep;
    }
    if (!std::isfinite(slope)) continue;
    out.sector_angle_deg[s] = std::atan(-slope) * 180.0 / std::numbers::pi;
    fitted.push_back(out.sector_angle_deg[s]);
  }
  out.sectors_fitted = fitted.size();
  if (fitted.size() < 2 || 2 * fitted.size() < o.sectors) return out;
  const double m = std::accumulate(fitted.begin(), fitted.end(), 0.0) / static_cast<double>(fitted.size());
  double ss = 0.0;
  for (double a : fitted) ss += (a - m) * (a - m);
  out.angle_spread_deg = std::sqrt(ss / static_cast<double>(fitted.size() - 1));
  out.angle_min_deg = *std::min_element(fitted.begin(), fitted.end());
  out.angle_max_deg = *std::max_element(fitted.begin(), fitted.end());
  // A heap falls away from its axis: a mean slope that does not (a bed with a flat top whose
  // fitted band holds only noise, or a crater) is no heap. Its sector fits stay as diagnostics.
  out.valid = m > 0.0;
  out.angle_deg = out.valid ? m : 0.0;
  return out;
}

}  // namespace biodem::scenario
