// Checkpoint/restart (SPEC 10): the complete dynamic state of a run - bodies, contact history,
// neighbour-list bookkeeping, time, phase progress and output positions - in one binary file
// with a magic, a format version and a 64-bit FNV-1a checksum of the payload, written atomically
// (temporary file, fsync, rename). A resumed run continues bit for bit as if never stopped, on
// the same build and thread count.
#pragma once
#include <cstdint>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "sim/simulation.hpp"

namespace biodem::checkpoint {

// 2: no per-entry torque_i; 3: sparse wall contacts, removed bodies; 4: lost bodies; 5: insertion
// state (checkpoints during insertion), last sample and snapshot steps, the last settle verdict;
// 6: the engine that wrote it and, for the GPU engine, its family of contact sums.
inline constexpr std::uint32_t kCheckpointVersion = 6;
/// The oldest version load_checkpoint still reads (a version-4 file was never written during
/// insertion; what it lacks is filled in as the run driver of that version assumed it).
inline constexpr std::uint32_t kOldestReadableCheckpointVersion = 4;

/// Insertion in waves, when the checkpoint was taken between two waves (issue 10, item 5).
struct InsertionProgress {
  bool active = false;              // insertion still under way
  std::uint64_t placed = 0;         // requests placed so far (index of the next one)
  std::uint64_t waves = 0;          // waves done
  std::uint64_t empty_waves = 0;    // consecutive waves that placed nothing
  std::uint64_t fall_step = 0;      // steps done of the fall that follows the last wave
  std::mt19937_64 rng;              // the insertion's random generator after the last wave
};

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
  // Version 5 on (a version-4 file leaves them as below and `version` says so).
  std::uint32_t version = kCheckpointVersion;  // of the file read
  static constexpr std::uint64_t kNever = ~std::uint64_t{0};
  std::uint64_t last_sample_step = kNever;     // step of the last series.csv row
  std::uint64_t last_snapshot_step = kNever;   // step of the last snapshot
  bool last_settled = false;                   // the last settle-criterion phase ended at rest
  InsertionProgress insertion;
  // Version 6 on (empty when read from an older file): the engine that wrote the checkpoint
  // ("cpu", "gpu" or "gpu-emulated") and, for the GPU engine, its family of contact sums
  // ("ordered" or "fixed", docs/gpu.md section 2), so that a resumed run can go on with the
  // family it was written with, and say so when it goes on with another engine or family.
  std::string engine;
  std::string contact_sums;
};

void save_checkpoint(const std::string& path, const sim::Simulation& sim, const RunProgress& progress);
/// Restores into a Simulation built from the same case (same walls, templates, materials).
/// Throws biodem::Error naming the file when it is missing, truncated, corrupt or of another version.
RunProgress load_checkpoint(const std::string& path, sim::Simulation& sim);
/// The case-file hash a checkpoint was written for (RunProgress::case_hash), after the checks of
/// its header and checksum, without loading its state: a checkpoint of another case is named as
/// such before its state could fail to fit this case's.
std::uint64_t checkpoint_case_hash(const std::string& path);
/// Same for the bytes of a checkpoint file already in memory (`path` is used in messages).
RunProgress load_checkpoint_bytes(const std::vector<char>& bytes, const std::string& path, sim::Simulation& sim);

std::uint64_t fnv1a(const void* data, std::size_t n, std::uint64_t h = 1469598103934665603ull);

}  // namespace biodem::checkpoint
