#include "driver/runner.hpp"

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <numbers>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "output/output_dir.hpp"
#include "scenario/bulk_measures.hpp"

namespace biodem::driver {

// Responses of a bulk test (SPEC 7, 11), measured on the final state: docs/calibration.md.
void Runner::write_responses() {
  const auto& b = *cfg_.bulk_test;
  const auto& s = sim_.spheres();
  const auto& bd = sim_.bodies();
  struct Row {
    std::string name;
    double value;
    std::string unit;
  };
  std::vector<Row> rows;
  std::vector<std::string> warnings;  // responses that may not mean what they say
  double d = 0.0;  // profile bin: the largest volume-equivalent diameter of the poured shapes
  for (const auto& p : built_.populations) d = std::max(d, sim_.templates()[p.shape].equivalent_diameter_m());
  if (b.kind == config::BulkTest::Kind::Heap) {
    scenario::HeapOptions o;
    o.bin_m = d;
    o.sectors = b.sectors;
    o.fit_from = b.fit_from_fraction;
    o.fit_to = b.fit_to_fraction;
    const auto h = scenario::measure_heap(s.position_m, s.radius_m, s.body, {0, 0, 0}, {0, 1, 0}, o);
    rows.push_back({"angle_of_repose_deg", h.angle_deg, "deg"});
    rows.push_back({"angle_of_repose_spread_deg", h.angle_spread_deg, "deg"});
    rows.push_back({"angle_of_repose_min_deg", h.angle_min_deg, "deg"});
    rows.push_back({"angle_of_repose_max_deg", h.angle_max_deg, "deg"});
    rows.push_back({"heap_sectors_fitted", static_cast<double>(h.sectors_fitted), "-"});
    rows.push_back({"heap_sectors_steep", static_cast<double>(h.sectors_steep), "-"});
    rows.push_back({"heap_height_m", h.height_m, "m"});
    rows.push_back({"heap_base_radius_m", h.base_radius_m, "m"});
    rows.push_back({"heap_bodies", static_cast<double>(h.heap_bodies), "-"});
    rows.push_back({"stray_bodies", static_cast<double>(h.stray_bodies), "-"});
    rows.push_back({"heap_found", h.valid ? 1.0 : 0.0, "-"});
    rows.push_back({"lifted_bodies", static_cast<double>(h.lifted_bodies), "-"});
    // A heap only a few particles high is rough and flat at the scale of its fitted band (20 to
    // 80 % of its height spans a few bins): its angle says more about single particles than
    // about the powder (the quick example's heap, 5 beads high: 20.4 degrees; 3,200 of the same
    // beads, 9.6 high: 30.1; docs/calibration.md).
    if (h.sectors_steep > 0) {
      char buf[256];
      std::snprintf(buf, sizeof buf,
                    "WARNING: heap: %zu of %zu fitted sectors are too steep for 3 profile bins in the fitted band "
                    "(base radius %.3g mm, bins %.3g mm): their angles come from the band's crossings, coarser",
                    h.sectors_steep, h.sectors_fitted, h.base_radius_m * 1e3, d * 1e3);
      warnings.push_back(buf);
    }
    if (h.height_m > 0.0 && h.height_m < 10.0 * d) {
      char buf[256];
      std::snprintf(buf, sizeof buf,
                    "WARNING: heap: it stands %.3g particle sizes high (d_eq %.3g mm): under 10, its fitted angle "
                    "depends on single particles; pour more ([insertion].count) into a wider cylinder "
                    "([heap].cylinder_diameter_m)",
                    h.height_m / d, d * 1e3);
      warnings.push_back(buf);
    }
    // Bodies more than a particle size above the heap's top, at rest, can only be held by the
    // lifted cylinder (cohesion or friction with its material): then the heap is not the
    // powder's free flow, and a missing heap does not mean that it flowed flat.
    if (h.lifted_bodies > 0 && static_cast<double>(h.lifted_bodies) > 0.05 * static_cast<double>(bd.size()))
      warnings.push_back("WARNING: heap: " + std::to_string(h.lifted_bodies) + " of " + std::to_string(bd.size()) +
                         " bodies are more than a particle size above the heap's top: held up by the lifted cylinder"
                         " ([heap] cylinder_material = '" + cfg_.materials[b.cylinder_material].name +
                         "': its cohesion or friction with the particles); the heap does not show the powder's angle "
                         "of repose");
  } else if (b.kind == config::BulkTest::Kind::BulkDensity) {
    const double R = 0.5 * b.container_diameter_m, H = b.container_height_m;
    double m = 0.0, v = 0.0, y_max = -1e300, v_core = 0.0;
    const double rc = R - d;  // core: one particle size away from the wall, the bottom and the rim
    for (std::size_t i = 0; i < bd.size(); ++i) {
      const Vec3 x = bd.position_m[i];
      y_max = std::max(y_max, x.y);
      if (x.y > d && x.y < H - d && x.x * x.x + x.z * x.z < rc * rc) v_core += sim_.templates()[bd.shape[i]].volume_m3;
      if (x.y > H || x.x * x.x + x.z * x.z > R * R || x.y < 0.0) continue;  // struck off, or outside
      m += bd.mass_kg[i];
      v += sim_.templates()[bd.shape[i]].volume_m3;
    }
    if (!(y_max > H))
      throw Error("[insertion].count = " + std::to_string(bd.size() + sim_.removed_bodies()) +
                  ": the container did not overflow (highest body centre at " + std::to_string(y_max) +
                  " m, rim at " + std::to_string(H) + " m); pour more particles");
    const double volume = std::numbers::pi * R * R * H;
    rows.push_back({"bulk_density_kg_m3", m / volume, "kg/m3"});
    rows.push_back({"solid_fraction", v / volume, "-"});
    rows.push_back({"mass_in_container_kg", m, "kg"});
    if (rc > 0.0 && H > 2.0 * d)
      rows.push_back({"core_solid_fraction", v_core / (std::numbers::pi * rc * rc * (H - 2.0 * d)), "-"});
  } else {
    double m_in = 0.0, m_all = sim_.removed_mass_kg();
    for (std::size_t i = 0; i < bd.size(); ++i) {
      m_all += bd.mass_kg[i];
      if (bd.position_m[i].x < b.length_m) m_in += bd.mass_kg[i];
    }
    rows.push_back({"retainment_ratio", m_all > 0.0 ? m_in / m_all : 0.0, "-"});
    rows.push_back({"mass_retained_kg", m_in, "kg"});
    rows.push_back({"mass_poured_kg", m_all, "kg"});
  }
  rows.push_back({"at_rest", last_settled_ ? 1.0 : 0.0, "-"});
  const std::string path = opt_.out_dir + "/responses.csv";
  std::string text = "response,value,unit\n";
  char buf[64];
  for (const auto& r : rows) {
    std::snprintf(buf, sizeof buf, "%.9g", r.value);
    text += r.name + "," + buf + "," + r.unit + "\n";
  }
  output::write_file_atomic(path, text);  // (whole or not at all; a write error stops the run)
  for (const auto& w : warnings) log_ << w << "\n";
  log_ << "responses (" << path << "):";
  for (const auto& r : rows) log_ << " " << r.name << " = " << r.value << " " << r.unit << ";";
  log_ << (last_settled_ ? "" : " WARNING: the scene was not at rest when measured (max_rest_s reached)") << "\n";
}

}  // namespace biodem::driver
