#include "shapes/mass_properties.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace biodem::shapes {
namespace {
constexpr double pi = std::numbers::pi;

/// Adds sign * (the cap of sphere (c, r) beyond the plane at distance a along unit u).
void add_cap(MassProperties& mp, const Vec3& c, double r, const Vec3& u, double a, double sign) {
  auto vol = [r](double z) { return r * r * z - z * z * z / 3.0; };
  auto m1 = [r](double z) { return r * r * z * z / 2.0 - z * z * z * z / 4.0; };
  auto mzz = [r](double z) { return r * r * z * z * z / 3.0 - std::pow(z, 5) / 5.0; };
  auto mxx = [r](double z) {  // int (r^2 - z^2)^2 / 4 dz
    return (std::pow(r, 4) * z - 2.0 * r * r * z * z * z / 3.0 + std::pow(z, 5) / 5.0) / 4.0;
  };
  const double v = pi * (vol(r) - vol(a));
  const double fz = pi * (m1(r) - m1(a));
  const double szz = pi * (mzz(r) - mzz(a));
  const double sxx = pi * (mxx(r) - mxx(a));
  // p = c + z u + x e1 + y e2:  int p p^T = v c c^T + fz (c u^T + u c^T) + szz u u^T + sxx (I - u u^T)
  const Mat3 j = v * outer(c, c) + fz * (outer(c, u) + outer(u, c)) + szz * outer(u, u) +
                 sxx * (Mat3::identity() + (-1.0) * outer(u, u));
  mp.volume_m3 += sign * v;
  mp.first_moment_m4 += sign * (v * c + fz * u);
  mp.second_moment_m5 = mp.second_moment_m5 + sign * j;
}

bool three_overlap(const std::vector<Vec3>& c, const std::vector<double>& r) {
  const std::size_t n = c.size();
  auto ov = [&](std::size_t i, std::size_t j) { return norm(c[i] - c[j]) < r[i] + r[j]; };
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t j = i + 1; j < n; ++j) {
      if (!ov(i, j)) continue;
      for (std::size_t k = j + 1; k < n; ++k)
        if (ov(i, k) && ov(j, k)) return true;
    }
  return false;
}
}  // namespace

Mat3 MassProperties::inertia_about_centroid_m5() const {
  const Vec3 g = centroid_m();
  const Mat3 jc = second_moment_m5 + (-volume_m3) * outer(g, g);  // parallel-axis shift
  const double tr = jc(0, 0) + jc(1, 1) + jc(2, 2);
  return tr * Mat3::identity() + (-1.0) * jc;
}

MassProperties union_of_spheres(const std::vector<Vec3>& c, const std::vector<double>& r) {
  bool nested = false;
  for (std::size_t i = 0; i < c.size(); ++i)
    for (std::size_t j = i + 1; j < c.size(); ++j)
      if (norm(c[i] - c[j]) <= std::abs(r[i] - r[j])) nested = true;
  if (nested || three_overlap(c, r)) return union_of_spheres_numerical(c, r, 240);

  MassProperties mp;
  for (std::size_t i = 0; i < c.size(); ++i) add_cap(mp, c[i], r[i], Vec3{0, 0, 1}, -r[i], +1.0);
  for (std::size_t i = 0; i < c.size(); ++i)
    for (std::size_t j = i + 1; j < c.size(); ++j) {
      const Vec3 dvec = c[j] - c[i];
      const double d = norm(dvec);
      if (d >= r[i] + r[j]) continue;
      const Vec3 u = dvec / d;
      const double a_i = (d * d + r[i] * r[i] - r[j] * r[j]) / (2.0 * d);  // plane distance from c_i
      add_cap(mp, c[i], r[i], u, a_i, -1.0);
      add_cap(mp, c[j], r[j], -u, d - a_i, -1.0);
    }
  return mp;
}

MassProperties union_of_spheres_numerical(const std::vector<Vec3>& c, const std::vector<double>& r,
                                          int resolution) {
  Vec3 lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
  for (std::size_t i = 0; i < c.size(); ++i)
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], c[i][k] - r[i]);
      hi[k] = std::max(hi[k], c[i][k] + r[i]);
    }
  const double h = std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z}) / resolution;
  int n[3];
  for (int k = 0; k < 3; ++k) n[k] = std::max(1, static_cast<int>(std::ceil((hi[k] - lo[k]) / h)));
  const double dv = h * h * h;
  MassProperties mp;
  mp.exact = false;
  for (int ix = 0; ix < n[0]; ++ix)
    for (int iy = 0; iy < n[1]; ++iy)
      for (int iz = 0; iz < n[2]; ++iz) {
        const Vec3 p{lo.x + (ix + 0.5) * h, lo.y + (iy + 0.5) * h, lo.z + (iz + 0.5) * h};
        bool inside = false;
        for (std::size_t i = 0; i < c.size() && !inside; ++i) inside = norm2(p - c[i]) <= r[i] * r[i];
        if (!inside) continue;
        mp.volume_m3 += dv;
        mp.first_moment_m4 += dv * p;
        mp.second_moment_m5 = mp.second_moment_m5 + dv * outer(p, p);
      }
  return mp;
}

}  // namespace biodem::shapes
