// heap_measure: biodem's angle-of-repose measurement (scenario::measure_heap, docs/calibration.md
// "Measuring the heap") applied to any list of spheres, so that a heap simulated by another code
// (LIGGGHTS 3.8.0, bench/heap_peer/) is measured exactly as biodem measures its own.
//
//   heap_measure SPHERES.csv --bin-m B [--sectors 8] [--up y|z|x] [--origin X,Y,Z]
//                [--fit-from 0.2] [--fit-to 0.8] [--sink-m S]
//
// SPHERES.csv: one sphere a line, `x,y,z,radius,body_id` (metres; spheres of one rigid body share
// its body id). A first line that does not start with a number (a header) and lines starting
// with '#' are skipped. The plate is the plane through --origin normal to --up, the heap axis the
// line through --origin along --up. --sink-m S drops every body with a sphere centre below S
// (along --up, measured from the origin), as biodem's sink below the plate removes them.
// Output: `key = value` lines (angle mean, spread = sample standard deviation over the fitted
// sectors, min, max, per-sector angles, height, base radius, heap and stray bodies).
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <unordered_set>
#include <vector>

#include "scenario/bulk_measures.hpp"

using namespace biodem;

namespace {

[[noreturn]] void usage(const std::string& why) {
  std::cerr << "heap_measure: " << why << "\n"
            << "usage: heap_measure SPHERES.csv --bin-m B [--sectors N] [--up x|y|z] [--origin X,Y,Z]\n"
            << "                    [--fit-from F] [--fit-to F] [--sink-m S]\n"
            << "  SPHERES.csv: x,y,z,radius,body_id per line (m); header and '#' lines skipped\n";
  std::exit(2);
}

double number(const std::string& s, const std::string& flag) {
  char* end = nullptr;
  const double v = std::strtod(s.c_str(), &end);
  if (end == s.c_str() || *end != '\0' || !std::isfinite(v)) usage(flag + ": not a number: '" + s + "'");
  return v;
}

}  // namespace

int main(int argc, char** argv) {
  std::string path;
  scenario::HeapOptions o;
  Vec3 up{0, 1, 0}, origin{0, 0, 0};
  bool have_sink = false;
  double sink_m = 0.0;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) usage(a + " needs a value");
      return argv[++i];
    };
    if (a == "--bin-m") {
      o.bin_m = number(value(), a);
    } else if (a == "--sectors") {
      const double k = number(value(), a);
      if (!(k >= 1.0 && k == std::floor(k))) usage("--sectors: a whole number >= 1");
      o.sectors = static_cast<std::size_t>(k);
    } else if (a == "--up") {
      const std::string u = value();
      if (u == "x") up = {1, 0, 0};
      else if (u == "y") up = {0, 1, 0};
      else if (u == "z") up = {0, 0, 1};
      else usage("--up: x, y or z");
    } else if (a == "--origin") {
      std::stringstream ss(value());
      std::string part;
      int k = 0;
      while (std::getline(ss, part, ',') && k < 3) origin[k++] = number(part, a);
      if (k != 3) usage("--origin: X,Y,Z");
    } else if (a == "--fit-from") {
      o.fit_from = number(value(), a);
    } else if (a == "--fit-to") {
      o.fit_to = number(value(), a);
    } else if (a == "--sink-m") {
      sink_m = number(value(), a);
      have_sink = true;
    } else if (a == "-h" || a == "--help") {
      usage("measures a heap of spheres as biodem's [heap] test does");
    } else if (!a.empty() && a[0] == '-') {
      usage("unknown option " + a);
    } else if (path.empty()) {
      path = a;
    } else {
      usage("one input file only");
    }
  }
  if (path.empty()) usage("no input file");
  if (!(o.bin_m > 0.0)) usage("--bin-m: required, > 0 (biodem uses the volume-equivalent diameter)");
  if (!(o.fit_to > o.fit_from)) usage("--fit-to must exceed --fit-from");

  std::ifstream in(path);
  if (!in) usage("cannot read " + path);
  std::vector<Vec3> centres;
  std::vector<double> radii;
  std::vector<std::uint32_t> body;
  std::string line;
  std::size_t line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    if (line.empty() || line[0] == '#') continue;
    const char c0 = line[0];
    const bool numeric = (c0 >= '0' && c0 <= '9') || c0 == '-' || c0 == '+' || c0 == '.';
    if (!numeric) {
      if (line_no == 1) continue;  // header
      usage(path + ":" + std::to_string(line_no) + ": not a sphere line");
    }
    std::stringstream ss(line);
    std::string f[5];
    int k = 0;
    while (k < 5 && std::getline(ss, f[k], ',')) ++k;
    if (k != 5) usage(path + ":" + std::to_string(line_no) + ": expected x,y,z,radius,body_id");
    const std::string where = path + ":" + std::to_string(line_no);
    centres.push_back({number(f[0], where), number(f[1], where), number(f[2], where)});
    radii.push_back(number(f[3], where));
    const double b = number(f[4], where);
    if (!(b >= 0.0 && b == std::floor(b) && b < 4294967296.0)) usage(where + ": body_id must be a whole number >= 0");
    body.push_back(static_cast<std::uint32_t>(b));
  }
  std::size_t sunk = 0;
  if (have_sink) {
    std::unordered_set<std::uint32_t> below;
    for (std::size_t i = 0; i < centres.size(); ++i)
      if (dot(centres[i] - origin, up) < sink_m) below.insert(body[i]);
    std::vector<Vec3> c2;
    std::vector<double> r2;
    std::vector<std::uint32_t> b2;
    for (std::size_t i = 0; i < centres.size(); ++i) {
      if (below.count(body[i])) continue;
      c2.push_back(centres[i]), r2.push_back(radii[i]), b2.push_back(body[i]);
    }
    sunk = below.size();
    centres.swap(c2), radii.swap(r2), body.swap(b2);
  }

  const auto h = scenario::measure_heap(centres, radii, body, origin, up, o);
  std::printf("spheres = %zu\n", centres.size());
  if (have_sink) std::printf("sunk_bodies = %zu\n", sunk);
  std::printf("heap_found = %d\n", h.valid ? 1 : 0);
  std::printf("angle_of_repose_deg = %.6f\n", h.angle_deg);
  std::printf("angle_of_repose_spread_deg = %.6f\n", h.angle_spread_deg);
  std::printf("angle_of_repose_min_deg = %.6f\n", h.angle_min_deg);
  std::printf("angle_of_repose_max_deg = %.6f\n", h.angle_max_deg);
  std::printf("sector_angles_deg =");
  for (double a : h.sector_angle_deg) std::printf(" %.3f", a);
  std::printf("\n");
  std::printf("heap_sectors_fitted = %zu\n", h.sectors_fitted);
  std::printf("heap_height_m = %.6g\n", h.height_m);
  std::printf("heap_base_radius_m = %.6g\n", h.base_radius_m);
  std::printf("heap_bodies = %zu\n", h.heap_bodies);
  std::printf("stray_bodies = %zu\n", h.stray_bodies);
  return h.valid ? 0 : 1;
}
