#include "scenario/insertion.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <unordered_map>

#include "core/random.hpp"

namespace biodem::scenario {
namespace {

// The trials of a wave are shared by its requests, as LIGGGHTS' insert/pack shares maxattempt
// over the particles of an insertion: max_attempts per request still to place, saturating.
// A request that needs more than max_attempts trials near the jamming limit of random
// sequential placement takes them from the budget instead of stopping the wave.
std::uint64_t wave_attempt_budget(std::size_t requests, std::uint64_t max_attempts) {
  const auto n = static_cast<std::uint64_t>(requests);
  if (n != 0 && max_attempts > std::numeric_limits<std::uint64_t>::max() / n)
    return std::numeric_limits<std::uint64_t>::max();
  return n * max_attempts;
}

/// Hash grid of sphere centres for overlap tests during insertion.
class SphereHash {
 public:
  explicit SphereHash(double cell) : cell_(cell) {}
  void add(const Vec3& c, double r) {
    centers_.push_back(c);
    radii_.push_back(r);
    map_[key(c)].push_back(static_cast<std::uint32_t>(centers_.size() - 1));
  }
  bool overlaps(const Vec3& c, double r) const {
    const long cx = coord(c.x), cy = coord(c.y), cz = coord(c.z);
    for (long dx = -1; dx <= 1; ++dx)
      for (long dy = -1; dy <= 1; ++dy)
        for (long dz = -1; dz <= 1; ++dz) {
          auto it = map_.find(pack(cx + dx, cy + dy, cz + dz));
          if (it == map_.end()) continue;
          for (std::uint32_t k : it->second) {
            const double s = r + radii_[k];
            if (norm2(c - centers_[k]) < s * s) return true;
          }
        }
    return false;
  }

 private:
  long coord(double x) const { return static_cast<long>(std::floor(x / cell_)); }
  static std::uint64_t pack(long x, long y, long z) {
    return (static_cast<std::uint64_t>(x & 0x1fffff) << 42) | (static_cast<std::uint64_t>(y & 0x1fffff) << 21) |
           static_cast<std::uint64_t>(z & 0x1fffff);
  }
  std::uint64_t key(const Vec3& c) const { return pack(coord(c.x), coord(c.y), coord(c.z)); }
  double cell_;
  std::vector<Vec3> centers_;
  std::vector<double> radii_;
  std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> map_;
};

/// The body of a request placed at `pos` with orientation `q`.
void add_placed_body(sim::Simulation& sim, const InsertionRequest& req, const Vec3& pos, const Quat& q) {
  sim::BodyInit b;
  b.shape = req.shape;
  b.material = req.material;
  b.position_m = pos;
  b.orientation = q;
  sim.add_body(b);
}

}  // namespace

Quat random_orientation(std::mt19937_64& rng) {
  constexpr auto u = uniform01;  // core/random.hpp: the same numbers with every library
  const double u1 = u(rng), u2 = u(rng), u3 = u(rng);
  const double a = std::sqrt(1.0 - u1), b = std::sqrt(u1), tp = 2.0 * std::numbers::pi;
  return normalized(Quat{b * std::cos(tp * u3), a * std::sin(tp * u2), a * std::cos(tp * u2), b * std::sin(tp * u3)});
}

std::vector<InsertionRequest> plan_population(std::uint64_t count, const std::vector<double>& fractions,
                                              const std::vector<double>& volumes,
                                              const std::vector<InsertionRequest>& pops, std::mt19937_64& rng) {
  // Number fraction of population k is proportional to (volume fraction / particle volume).
  std::vector<double> w(pops.size());
  double sum = 0.0;
  for (std::size_t k = 0; k < pops.size(); ++k) sum += (w[k] = fractions[k] / volumes[k]);
  std::vector<std::uint64_t> n(pops.size());
  std::vector<std::pair<double, std::size_t>> rem;
  std::uint64_t assigned = 0;
  for (std::size_t k = 0; k < pops.size(); ++k) {
    const double exact = static_cast<double>(count) * w[k] / sum;
    n[k] = static_cast<std::uint64_t>(std::floor(exact));
    assigned += n[k];
    rem.emplace_back(exact - std::floor(exact), k);
  }
  std::stable_sort(rem.begin(), rem.end(), [](auto& a, auto& b) { return a.first > b.first; });
  for (std::size_t q = 0; assigned < count; ++q, ++assigned) ++n[rem[q % rem.size()].second];
  std::vector<InsertionRequest> out;
  out.reserve(count);
  for (std::size_t k = 0; k < pops.size(); ++k) out.insert(out.end(), n[k], pops[k]);
  biodem::shuffle(out.begin(), out.end(), rng);  // core/random.hpp
  return out;
}

std::size_t insert_wave(sim::Simulation& sim, const CylinderRegion& reg, const std::vector<InsertionRequest>& todo,
                        std::size_t next, std::uint64_t max_attempts, std::mt19937_64& rng) {
  const auto& templates = sim.templates();
  double r_max = 0.0;
  for (const auto& t : templates) r_max = std::max(r_max, t.max_radius_m);
  for (double r : sim.spheres().radius_m) r_max = std::max(r_max, r);
  SphereHash hash(2.0 * r_max);
  const double width = reg.z_max_m - reg.z_min_m;
  auto add_with_images = [&](const Vec3& c, double r) {
    hash.add(c, r);
    if (reg.periodic_z) {
      hash.add(c + Vec3{0, 0, width}, r);
      hash.add(c - Vec3{0, 0, width}, r);
    }
  };
  // Existing spheres (positions possibly unwrapped on a periodic axis: wrap into the region).
  for (std::size_t i = 0; i < sim.spheres().size(); ++i) {
    Vec3 c = sim.spheres().position_m[i];
    if (reg.periodic_z) c.z = reg.z_min_m + (c.z - reg.z_min_m) - width * std::floor((c.z - reg.z_min_m) / width);
    add_with_images(c, sim.spheres().radius_m[i]);
  }
  constexpr auto u = uniform01;  // core/random.hpp: the same numbers with every library
  std::vector<Vec3> placed;
  std::uint64_t budget = wave_attempt_budget(todo.size() - next, max_attempts);
  while (next < todo.size() && budget > 0) {
    const auto& req = todo[next];
    const auto& t = templates[req.shape];
    bool ok = false;
    for (; budget > 0 && !ok; --budget) {
      // Uniform point in the disc (area-uniform radius) and along z.
      const double rr = (reg.radius_m - t.bounding_radius_m) * std::sqrt(u(rng));
      const double phi = 2.0 * std::numbers::pi * u(rng);
      const double zlo = reg.periodic_z ? reg.z_min_m : reg.z_min_m + t.max_radius_m;
      const double zhi = reg.periodic_z ? reg.z_max_m : reg.z_max_m - t.max_radius_m;
      const Vec3 pos{rr * std::cos(phi), rr * std::sin(phi), zlo + (zhi - zlo) * u(rng)};
      const Quat q = t.sphere_count() > 1 ? random_orientation(rng) : Quat{};
      placed.clear();
      ok = true;
      for (std::size_t k = 0; k < t.sphere_count() && ok; ++k) {
        const Vec3 c = pos + rotate(q, t.offsets_m[k]);
        const double r = t.radii_m[k];
        if (!reg.periodic_z && (c.z - r < reg.z_min_m || c.z + r > reg.z_max_m)) ok = false;
        if (c.x * c.x + c.y * c.y > (reg.radius_m - r) * (reg.radius_m - r)) ok = false;
        if (ok && hash.overlaps(c, r)) ok = false;
        placed.push_back(c);
      }
      if (!ok) continue;
      for (std::size_t k = 0; k < t.sphere_count(); ++k) add_with_images(placed[k], t.radii_m[k]);
      add_placed_body(sim, req, pos, q);
    }
    if (ok) ++next;
  }
  return next;
}

double Region::volume_m3() const {
  if (kind == Kind::Box) return (max_m.x - min_m.x) * (max_m.y - min_m.y) * (max_m.z - min_m.z);
  return std::numbers::pi * radius_m * radius_m * height_m;
}

bool Region::contains(const Vec3& c, double r) const {
  if (kind == Kind::Box)
    return c.x - r >= min_m.x && c.y - r >= min_m.y && c.z - r >= min_m.z && c.x + r <= max_m.x &&
           c.y + r <= max_m.y && c.z + r <= max_m.z;
  const Vec3 d = c - base_m;
  const double h = dot(d, axis);
  if (h - r < 0.0 || h + r > height_m) return false;
  return norm2(d - h * axis) <= (radius_m - r) * (radius_m - r) && r <= radius_m;
}

std::size_t insert_wave(sim::Simulation& sim, const Region& reg, const std::vector<InsertionRequest>& todo,
                        std::size_t next, std::uint64_t max_attempts, std::mt19937_64& rng) {
  const auto& templates = sim.templates();
  double r_max = 0.0;
  for (const auto& t : templates) r_max = std::max(r_max, t.max_radius_m);
  for (double r : sim.spheres().radius_m) r_max = std::max(r_max, r);
  SphereHash hash(2.0 * r_max);
  for (std::size_t i = 0; i < sim.spheres().size(); ++i) hash.add(sim.spheres().position_m[i], sim.spheres().radius_m[i]);
  // An orthonormal frame of the cylinder axis.
  const Vec3 a = reg.axis;
  const Vec3 e1 = normalized(std::abs(a.x) < 0.9 ? cross(a, Vec3{1, 0, 0}) : cross(a, Vec3{0, 1, 0}));
  const Vec3 e2 = cross(a, e1);
  constexpr auto u = uniform01;  // core/random.hpp: the same numbers with every library
  std::vector<Vec3> placed;
  std::uint64_t budget = wave_attempt_budget(todo.size() - next, max_attempts);
  while (next < todo.size() && budget > 0) {
    const auto& req = todo[next];
    const auto& t = templates[req.shape];
    const double b = t.bounding_radius_m;
    bool ok = false;
    for (; budget > 0 && !ok; --budget) {
      // Body centre uniform in the region shrunk by the bounding radius (when it fits), so that
      // few trials fall outside.
      Vec3 pos;
      if (reg.kind == Region::Kind::Box) {
        for (int ax = 0; ax < 3; ++ax) {
          double lo = reg.min_m[ax] + b, hi = reg.max_m[ax] - b;
          if (lo > hi) lo = hi = 0.5 * (reg.min_m[ax] + reg.max_m[ax]);
          pos[ax] = lo + (hi - lo) * u(rng);
        }
      } else {
        const double rr = std::max(0.0, reg.radius_m - b) * std::sqrt(u(rng));
        const double phi = 2.0 * std::numbers::pi * u(rng);
        double lo = b, hi = reg.height_m - b;
        if (lo > hi) lo = hi = 0.5 * reg.height_m;
        pos = reg.base_m + (lo + (hi - lo) * u(rng)) * a + rr * std::cos(phi) * e1 + rr * std::sin(phi) * e2;
      }
      const Quat q = t.sphere_count() > 1 ? random_orientation(rng) : Quat{};
      placed.clear();
      ok = true;
      for (std::size_t s = 0; s < t.sphere_count() && ok; ++s) {
        const Vec3 c = pos + rotate(q, t.offsets_m[s]);
        const double r = t.radii_m[s];
        if (!reg.contains(c, r) || hash.overlaps(c, r)) ok = false;
        placed.push_back(c);
      }
      if (!ok) continue;
      for (std::size_t s = 0; s < t.sphere_count(); ++s) hash.add(placed[s], t.radii_m[s]);
      add_placed_body(sim, req, pos, q);
    }
    if (ok) ++next;
  }
  return next;
}

}  // namespace biodem::scenario
