#include "case_file/derived_quantities.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <numbers>
#include <set>
#include <sstream>
#include <utility>
#include <vector>

#include "contact/time_step.hpp"
#include "neighbor/skin.hpp"
#include "shapes/clump_template.hpp"

namespace biodem::case_file {
namespace {

constexpr double pi = std::numbers::pi;

double mean_population_volume(const config::CaseConfig& c, const std::map<std::size_t, shapes::ClumpTemplate>& t) {
  double inv = 0.0;
  for (const auto& p : c.populations) inv += p.volume_fraction / t.at(p.shape).volume_m3;
  return inv > 0.0 ? 1.0 / inv : 0.0;
}

std::uint64_t implied_count(const config::CaseConfig& c, const std::map<std::size_t, shapes::ClumpTemplate>& t) {
  if (!c.insertion) return 0;
  if (c.insertion->count) return *c.insertion->count;
  if (!c.insertion->fill_fraction || !c.drum) return 0;
  const double v = mean_population_volume(c, t);
  if (v <= 0.0) return 0;
  const double n = *c.insertion->fill_fraction * c.insertion->bulk_solid_fraction * drum_volume_m3(*c.drum) / v;
  return static_cast<std::uint64_t>(std::llround(n));
}

}  // namespace

std::vector<std::pair<std::size_t, std::size_t>> particle_types(const config::CaseConfig& c) {
  std::vector<std::pair<std::size_t, std::size_t>> out;
  auto add = [&](std::size_t m, std::size_t s) {
    if (std::find(out.begin(), out.end(), std::make_pair(m, s)) == out.end()) out.emplace_back(m, s);
  };
  for (const auto& p : c.populations) add(p.material, p.shape);
  for (const auto& p : c.particles) add(p.material, p.shape);
  return out;
}

std::map<std::size_t, shapes::ClumpTemplate> used_templates(const config::CaseConfig& c) {
  std::map<std::size_t, shapes::ClumpTemplate> t;
  const double s = particle_coarse_grain(c);
  for (const auto& [m, sh] : particle_types(c))
    if (!t.count(sh)) t.emplace(sh, shapes::make_template(c.shapes.at(sh), s));
  return t;
}

double particle_coarse_grain(const config::CaseConfig& c) { return c.insertion ? c.insertion->coarse_grain : 1.0; }

double drum_volume_m3(const config::Drum& d) { return pi * d.diameter_m * d.diameter_m / 4.0 * d.width_m; }

double mean_population_particle_volume_m3(const config::CaseConfig& c) {
  return mean_population_volume(c, used_templates(c));
}

std::uint64_t implied_particle_count(const config::CaseConfig& c) { return implied_count(c, used_templates(c)); }

double smallest_rayleigh_time_s(const config::CaseConfig& c) {
  const auto t = used_templates(c);
  double best = std::numeric_limits<double>::infinity();
  for (const auto& [m, s] : particle_types(c)) {
    const auto& mat = c.materials.at(m);
    if (!mat.density_kg_m3) continue;
    best = std::min(best, contact::rayleigh_time_s(t.at(s).min_radius_m, *mat.density_kg_m3, mat.young_pa,
                                                   mat.poisson));
  }
  return best;
}

double resolved_skin_m(const config::CaseConfig& c) {
  if (c.run.skin_m) return *c.run.skin_m;
  double rmin = std::numeric_limits<double>::infinity();
  for (const auto& [s, t] : used_templates(c)) rmin = std::min(rmin, t.min_radius_m);
  return std::isfinite(rmin) ? neighbor::default_skin_m(rmin) : 0.0;
}

double speed_image_scale_m_s(const config::CaseConfig& c) {
  if (!c.drum) return 0.0;
  if (c.output.speed_image_max_m_s) return *c.output.speed_image_max_m_s;
  const double rim = std::abs(c.drum->rpm) * 2.0 * std::numbers::pi / 60.0 * 0.5 * c.drum->diameter_m;
  double d = 0.0;
  for (const auto& [s, t] : used_templates(c)) d = std::max(d, t.equivalent_diameter_m());
  const auto& g = c.run.gravity_m_s2;
  const double fall = std::sqrt(std::sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]) * d);
  const double top = std::max(2.0 * rim, fall);
  return top > 0.0 ? top : 0.1;
}

}  // namespace biodem::case_file
