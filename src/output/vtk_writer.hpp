// VTK XML output for ParaView: one .vtu (UnstructuredGrid of vertex cells, binary base64 data)
// per snapshot plus a .pvd collection indexing them by time. Files are written atomically.
#pragma once
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "core/vec3.hpp"

namespace biodem::output {

struct PointCloud {
  std::vector<Vec3> points;
  std::vector<std::pair<std::string, std::vector<double>>> scalars;
  std::vector<std::pair<std::string, std::vector<Vec3>>> vectors;
  std::vector<std::pair<std::string, std::vector<std::int64_t>>> ints;
  std::vector<std::pair<std::string, std::vector<std::array<double, 4>>>> quats;
};

/// Writes `cloud` as a .vtu file.
void write_vtu(const std::string& path, const PointCloud& cloud);

/// A .pvd collection that is rewritten (atomically) after each added file.
class PvdCollection {
 public:
  explicit PvdCollection(std::string path) : path_(std::move(path)) {}
  void add(double time_s, const std::string& relative_file);
  /// Re-reads nothing; used on resume to restore entries up to a time.
  void set_entries(std::vector<std::pair<double, std::string>> e) { entries_ = std::move(e); write(); }
  const std::vector<std::pair<double, std::string>>& entries() const { return entries_; }

 private:
  void write() const;
  std::string path_;
  std::vector<std::pair<double, std::string>> entries_;
};

}  // namespace biodem::output
