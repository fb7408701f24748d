// Checkpoint/restart (SPEC 10): the complete dynamic state of a run - bodies, contact history,
// neighbour-list bookkeeping, time, phase progress and output positions - in one binary file
// with a magic, a format version and a 64-bit FNV-1a checksum of the payload, written atomically
// (temporary file, fsync, rename). A resumed run continues bit for bit as if never stopped, on
// the same build and thread count.
#pragma once
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "sim/simulation.hpp"

namespace biodem::io {

inline constexpr std::uint32_t kCheckpointVersion = 4;  // 2: no per-entry torque_i; 3: sparse wall contacts, removed bodies; 4: lost bodies

/// Where the run driver was when the checkpoint was taken.
struct RunProgress {
  std::uint64_t case_hash = 0;        // FNV-1a of the case file text
  std::uint64_t phase_index = 0;      // phase in progress
  std::uint64_t phase_step = 0;       // steps done in that phase
  std::uint64_t settle_counter = 0;   // consecutive steps below the settle threshold
  double rotation_time_s = 0.0;       // time the drum has turned
  std::uint64_t snapshot_index = 0;
  std::uint64_t series_bytes = 0;     // size of series.csv at the checkpoint
  std::uint64_t trace_bytes = 0;
  std::vector<std::pair<double, std::string>> pvd_spheres, pvd_bodies;
};

void save_checkpoint(const std::string& path, const sim::Simulation& sim, const RunProgress& progress);
/// Restores into a Simulation built from the same case (same walls, templates, materials).
/// Throws biodem::Error naming the file when it is missing, truncated, corrupt or of another version.
RunProgress load_checkpoint(const std::string& path, sim::Simulation& sim);
/// Same for the bytes of a checkpoint file already in memory (`path` is used in messages).
RunProgress load_checkpoint_bytes(const std::vector<char>& bytes, const std::string& path, sim::Simulation& sim);

std::uint64_t fnv1a(const void* data, std::size_t n, std::uint64_t h = 1469598103934665603ull);

}  // namespace biodem::io
