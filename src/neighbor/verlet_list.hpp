// Linked-cell binning plus a half Verlet list with a skin and a displacement-triggered rebuild
// (Allen & Tildesley, Computer Simulation of Liquids, 2nd ed., sec. 5.3-5.4); O(N).
//
// The list is stored as CSR rows: row i holds the spheres j > i (of other bodies) closer than
// r_i + r_j + skin, sorted by j. Per-entry arrays hold the contact history and this step's pair
// results; a reverse index lists, for every sphere, the entries in which it is the j side, so a
// sphere can gather its forces in a fixed order without atomics (deterministic for any thread
// count). History survives rebuilds: a pair present in both lists keeps its history.
//
// Periodic axes: positions are never wrapped; each entry carries the integer image shift s such
// that the minimum-image separation is x_i - x_j - s * L.
#pragma once
#include <array>
#include <cstdint>
#include <utility>
#include <vector>

#include "contact/contact_model.hpp"
#include "core/vec3.hpp"
#include "neighbor/candidate_scan.hpp"
#include "state/particle_store.hpp"

namespace biodem::neighbor {

struct Domain {
  std::array<bool, 3> periodic{false, false, false};
  Vec3 lo_m, hi_m;  // used on periodic axes only
  bool any_periodic() const { return periodic[0] || periodic[1] || periodic[2]; }
  Vec3 length_m() const { return hi_m - lo_m; }
};

class VerletList {
 public:
  void configure(const Domain& domain, double skin_m) {
    domain_ = domain;
    skin_m_ = skin_m;
  }
  /// Rebuilds the list from current sphere positions, carrying history over. Between builds
  /// spheres may only be appended (new indices >= the old count, e.g. an insertion wave: the
  /// history of the existing pairs is kept); any other change of indices goes through renumber().
  void build(const state::SphereStore& spheres);
  /// Re-indexes the existing list after spheres were renumbered (new index = new_of_old[old]),
  /// keeping the history of touching pairs; the next build() merges it as usual. A pair whose
  /// order flips (new i > new j) has its history negated: history is stored from i's side.
  /// A sphere mapped to kRemoved is gone (its pairs are dropped).
  void renumber(const std::vector<std::uint32_t>& new_of_old);
  /// Fills row_of from row_start (row_start must be valid: non-decreasing, ending at j.size()).
  void index_rows();
  static constexpr std::uint32_t kRemoved = 0xFFFFFFFFu;
  /// True when some sphere moved more than half the skin since the last build.
  bool needs_rebuild(const state::SphereStore& spheres) const;
  /// Squared displacement since the last build beyond which the list must be rebuilt, (skin/2)^2.
  double rebuild_limit2() const { return 0.25 * skin_m_ * skin_m_; }

  std::size_t entries() const { return j.size(); }
  // Checkpoint access to the private bookkeeping (positions at the last build, build count).
  const std::vector<Vec3>& built_at() const { return built_at_; }
  void restore_bookkeeping(std::vector<Vec3> built_at, std::size_t builds) {
    built_at_ = std::move(built_at);
    builds_ = builds;
  }
  std::size_t builds() const { return builds_; }
  double skin_m() const { return skin_m_; }
  const Domain& domain() const { return domain_; }

  /// Minimum-image shift of entry k (zero when nothing is periodic).
  Vec3 shift(std::size_t k) const {
    const std::int32_t c = image[k];
    const Vec3 len = domain_.length_m();
    return {static_cast<double>(static_cast<std::int8_t>(c & 0xff)) * len.x,
            static_cast<double>(static_cast<std::int8_t>((c >> 8) & 0xff)) * len.y,
            static_cast<double>(static_cast<std::int8_t>((c >> 16) & 0xff)) * len.z};
  }

  // CSR rows (size n+1) and per-entry data.
  std::vector<std::uint32_t> row_start;
  std::vector<std::uint32_t> j;
  // The row (sphere i) of each entry: derived from row_start by index_rows(), which build() and
  // renumber() call, and a checkpoint load after it restores the rows. The pair pass walks the
  // entries of a range of rows in one flat loop with it (no branch at each row's end).
  std::vector<std::uint32_t> row_of;
  std::vector<std::int32_t> image;
  std::vector<contact::ContactHistory> history;
  std::vector<std::uint8_t> touching;
  std::vector<Vec3> force_i, torque_j;  // j's share of this step's pair result (force on i, torque on j)
  // Reverse index: entries where the sphere is the j side.
  std::vector<std::uint32_t> rev_start;
  std::vector<std::uint32_t> rev_entry;

 private:
  Domain domain_;
  double skin_m_ = 0.0;
  std::size_t builds_ = 0;
  std::vector<Vec3> built_at_;
  // Scratch of build(), kept between builds so that a build allocates nothing once grown.
  using RowEntry = ListEntry;
  // One cache line per chunk's vector: the threads push into neighbouring chunks at once, and
  // vector headers sharing a line made every push_back a transfer between cores.
  struct alignas(64) ChunkRows {
    std::vector<RowEntry> rows;
  };
  std::vector<ChunkRows> chunk_rows_;
  std::vector<std::uint32_t> row_len_;
  // The arrays of the build before the last one, reused by the next build (about 60 bytes per
  // list entry kept allocated, so that a build neither allocates nor clears serially).
  std::vector<std::uint32_t> spare_j_;
  std::vector<std::int32_t> spare_image_;
  std::vector<contact::ContactHistory> spare_history_;
  std::vector<std::uint8_t> spare_touching_;
  std::vector<double> scan_x_, scan_y_, scan_z_;
  std::vector<double> scan_r_;
  std::vector<std::uint32_t> scan_body_;
};

/// All pairs (i < j, different bodies) whose spheres overlap, by brute force: the reference for
/// testing the list. Returns (i, j) sorted.
std::vector<std::pair<std::uint32_t, std::uint32_t>> brute_force_overlaps(const state::SphereStore& spheres,
                                                                          const Domain& domain);

/// How many of the pairs (sphere indices, either order) the list lacks although their centres
/// are within its cut-off, r_i + r_j + skin (minimum image on periodic axes), at the positions of
/// s: pairs lost by bookkeeping rather than by motion. Pairs of one body are never listed and
/// not counted. (The GPU engine's check of the touching pairs it hands to a host list.)
std::size_t pairs_missing_within_cutoff(const VerletList& list, const state::SphereStore& s,
                                        const std::vector<std::pair<std::uint32_t, std::uint32_t>>& pairs);

}  // namespace biodem::neighbor
