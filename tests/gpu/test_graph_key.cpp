// The CUDA graph key (gpu/graph_key.hpp): two runs of steps share a captured graph only when
// everything that chooses their kernels, grid sizes and arguments is the same. Every
// combination of the parts must give its own key; in particular the timed choice's sets that
// differ only in the lanes per sphere of the packed walk (2 or 4) or per body.
#include <gtest/gtest.h>

#include <cstdint>
#include <unordered_set>

#include "gpu/graph_key.hpp"

using biodem::gpu::graph_key;
using biodem::gpu::GraphKeyParts;
using biodem::gpu::kMostUnitsInAGraph;

TEST(GraphKey, EveryCombinationOfItsPartsHasItsOwnKey) {
  std::unordered_set<std::uint64_t> keys;
  std::size_t n = 0;
  for (std::uint64_t generation : {0ull, 1ull, 2ull, 1000003ull})
    for (std::uint32_t units : {1u, 2u, 10u, kMostUnitsInAGraph - 1, kMostUnitsInAGraph})
      for (std::uint32_t bools = 0; bools < (1u << 10); ++bools)
        for (std::uint32_t body : {0u, 1u, 2u, 3u, 5u})
          for (std::uint32_t split = 0; split <= 2; ++split) {
            auto b = [&](unsigned k) { return ((bools >> k) & 1u) != 0; };
            const GraphKeyParts p{.generation = generation,
                                  .units = units,
                                  .translational = b(0),
                                  .settle = b(1),
                                  .fused = b(2),
                                  .sum_lanes = b(3),
                                  .walk_single = b(4),
                                  .entries = b(5),
                                  .queued_checks = b(6),
                                  .two_buffers = b(7),
                                  .fixed_sums = b(8),
                                  .walk_pack = b(9),
                                  .body_lanes_log2 = body,
                                  .pack_split_log2 = split};
            keys.insert(graph_key(p));
            ++n;
          }
  EXPECT_EQ(keys.size(), n);
}

TEST(GraphKey, TwoAndFourLanesPerSphereAreDifferentGraphs) {
  GraphKeyParts two{.generation = 7, .units = 10, .walk_single = true, .walk_pack = true, .pack_split_log2 = 1};
  GraphKeyParts four = two;
  four.pack_split_log2 = 2;
  GraphKeyParts off = two;
  off.pack_split_log2 = 0;
  EXPECT_NE(graph_key(two), graph_key(four));
  EXPECT_NE(graph_key(two), graph_key(off));
  EXPECT_NE(graph_key(four), graph_key(off));
  GraphKeyParts body2{.generation = 7, .units = 10, .walk_single = true, .body_lanes_log2 = 1};
  GraphKeyParts body8 = body2;
  body8.body_lanes_log2 = 3;
  EXPECT_NE(graph_key(body2), graph_key(body8));
  // A list build (a new generation) never finds a graph of the old rows.
  GraphKeyParts next = four;
  next.generation = 8;
  EXPECT_NE(graph_key(four), graph_key(next));
}
