// The key under which the GPU engine keeps a captured CUDA graph of one run of steps between two
// list checks (engine_impl.hpp, run_units). A graph bakes in its kernels, their grid sizes and
// arguments, so two runs may share one only if everything that chooses them is the same: the
// row generation (buffers reallocated by a list build), the number of steps, the criterion and
// every switch of the kernel set, the lane counts by value (the timed choice has sets that
// differ only in 2 or 4 lanes per sphere). Pure host code, tested on its own
// (tests/gpu/test_graph_key.cpp: every combination gives its own key).
#pragma once
#include <algorithm>
#include <cstdint>

namespace biodem::gpu {

struct GraphKeyParts {
  std::uint64_t generation = 0;     // rows_.generation (bits 24-63)
  std::uint32_t units = 0;          // steps in the graph, at most kMostUnitsInAGraph (bits 3-9)
  bool translational = false;       // the settle criterion's kind (bit 0)
  bool settle = false;              // the settle criterion evaluated on the device (bit 1)
  bool fused = false;               // kick/drift fused with the sphere update (bit 2)
  bool sum_lanes = false;           // (bit 10)
  bool walk_single = false;         // (bit 11)
  bool entries = false;             // per-contact kernels (bit 12)
  bool queued_checks = false;       // the list check queued on the device (bit 13)
  bool two_buffers = false;         // the walk with the body update, two motion buffers (bit 14)
  bool fixed_sums = false;          // the order-free family (bit 15)
  bool walk_pack = false;           // (bit 16)
  std::uint32_t body_lanes_log2 = 0;  // 0: off; else log2 of the lanes per body, <= 7 (bits 17-19)
  std::uint32_t pack_split_log2 = 0;  // 0: off; 1: 2 lanes per sphere, 2: 4 (bits 20-21)
};

/// Longer runs of steps are launched plainly, without a graph.
inline constexpr std::uint32_t kMostUnitsInAGraph = 64;

constexpr std::uint64_t graph_key(const GraphKeyParts& p) {
  static_assert(kMostUnitsInAGraph < (1u << 7), "units must fit bits 3-9");
  auto bit = [](bool b, unsigned k) { return b ? std::uint64_t{1} << k : std::uint64_t{0}; };
  return (p.generation << 24) | (std::uint64_t{std::min<std::uint32_t>(p.pack_split_log2, 3u)} << 20) |
         (std::uint64_t{std::min<std::uint32_t>(p.body_lanes_log2, 7u)} << 17) | bit(p.walk_pack, 16) |
         bit(p.fixed_sums, 15) | bit(p.two_buffers, 14) | bit(p.queued_checks, 13) | bit(p.entries, 12) |
         bit(p.walk_single, 11) | bit(p.sum_lanes, 10) | (std::uint64_t{std::min<std::uint32_t>(p.units, 127u)} << 3) |
         bit(p.fused, 2) | bit(p.settle, 1) | bit(p.translational, 0);
}

}  // namespace biodem::gpu
