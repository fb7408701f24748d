// Threading policy. Loops over fewer items than this run on one thread: for small systems the
// cost of waking and synchronising threads exceeds the work (and on a loaded machine a spinning
// team can stall for milliseconds). Results do not depend on it: every parallel loop writes
// disjoint outputs and sums in a fixed order.
#pragma once
#include <cstddef>

namespace biodem {
inline constexpr std::size_t kParallelThreshold = 2048;
}
