// Helpers for tests that drive the biodem binary like a user does.
#pragma once
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

namespace biodem::testing {

struct CommandResult {
  int status = -1;
  std::string output;  // stdout and stderr together
};

inline CommandResult run_command(const std::string& cmd) {
  CommandResult r;
  FILE* p = popen((cmd + " 2>&1").c_str(), "r");
  if (!p) return r;
  std::array<char, 4096> buf{};
  while (fgets(buf.data(), buf.size(), p)) r.output += buf.data();
  const int st = pclose(p);
  r.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  return r;
}

inline std::string biodem_exe() { return BIODEM_BINARY; }

/// The whole file as bytes ("" if it cannot be read).
inline std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}
inline std::string source_dir() { return BIODEM_SOURCE_DIR; }

/// The common part of the small explicit test scenes: a bead material (E = 5 MPa, nu = 0.3,
/// 2500 kg/m^3), its pair with itself (e = 0.5, mu = 0.3) and a sphere shape "bead" of the given
/// diameter (as written in the case).
inline std::string bead_material_pair_shape(const std::string& diameter_m) {
  return "[[material]]\nname = \"bead\"\ndensity_kg_m3 = 2500.0\nyoung_pa = 5.0e6\npoisson = 0.3\n\n"
         "[[pair]]\nmaterials = [\"bead\", \"bead\"]\nrestitution = 0.5\nsliding_friction = 0.3\n\n"
         "[[shape]]\nname = \"bead\"\nkind = \"sphere\"\ndiameter_m = " +
         diameter_m + "\n";
}
/// An explicit [[particle]] of that shape and material at `position_m` (TOML vector text), with
/// `extra` lines (a velocity) after it.
inline std::string bead_particle(const std::string& position_m, const std::string& extra = "") {
  return "\n[[particle]]\nshape = \"bead\"\nmaterial = \"bead\"\nposition_m = " + position_m + "\n" + extra;
}

/// A fresh, empty directory under the build tree's test folder.
/// The case file `source` with each (from, to) edit applied at its first occurrence (a from
/// that is not there fails the test), written as `name` in the working directory; returns its
/// path.
inline std::string edited_case(const std::string& source, const std::vector<std::pair<std::string, std::string>>& edits,
                               const std::string& name) {
  std::string text = slurp(source);
  for (const auto& [from, to] : edits) {
    const auto at = text.find(from);
    if (at == std::string::npos) {
      ADD_FAILURE() << source << ": edit not applied: " << from;
      continue;
    }
    text.replace(at, from.size(), to);
  }
  const std::string path = (std::filesystem::current_path() / name).string();
  std::ofstream(path) << text;
  return path;
}

inline std::string fresh_dir(const std::string& name) {
  const auto p = std::filesystem::current_path() / ("out_" + name);
  std::filesystem::remove_all(p);
  return p.string();
}

/// Reads a CSV with a header row into columns of strings.
inline std::map<std::string, std::vector<std::string>> read_csv(const std::string& path) {
  std::map<std::string, std::vector<std::string>> cols;
  std::ifstream in(path);
  std::string line;
  std::vector<std::string> header;
  if (!std::getline(in, line)) return cols;
  {
    std::stringstream ss(line);
    std::string c;
    while (std::getline(ss, c, ',')) header.push_back(c);
  }
  while (std::getline(in, line)) {
    std::stringstream ss(line);
    std::string c;
    for (std::size_t k = 0; k < header.size(); ++k) {
      if (!std::getline(ss, c, ',')) c.clear();
      cols[header[k]].push_back(c);
    }
  }
  return cols;
}

inline std::vector<double> to_numbers(const std::vector<std::string>& v) {
  std::vector<double> out;
  for (const auto& s : v) out.push_back(s.empty() ? std::nan("") : std::stod(s));
  return out;
}

}  // namespace biodem::testing
