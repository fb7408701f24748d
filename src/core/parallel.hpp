// Threading policy. Loops over fewer items than the threshold run on one thread: for small
// systems the cost of waking and synchronising threads exceeds the work (and on a loaded machine
// a spinning team can stall for milliseconds). Results do not depend on it: every parallel loop
// writes disjoint outputs and sums in a fixed order. Tests lower it to exercise the threaded
// paths on small systems.
#pragma once
#include <cstddef>

namespace biodem {
inline std::size_t kParallelThreshold = 2048;
inline void set_parallel_threshold(std::size_t n) { kParallelThreshold = n; }
}  // namespace biodem
