// Random numbers that mean the same with every compiler and standard library (issue 10, item 7).
// The engine std::mt19937_64 is fully specified by the C++ standard (its 10000th output for the
// default seed is fixed by [rand.predef]), but the distributions (std::uniform_real_distribution,
// std::uniform_int_distribution, std::shuffle) are not: libstdc++, libc++ and MSVC turn the same
// engine outputs into different numbers. biodem therefore draws only raw 64-bit outputs x from
// std::mt19937_64 and converts them itself:
//   uniform01(g):       u = double(x) * 2^-64, the conversion of x to double rounded to nearest
//                       (IEEE 754 default); if that rounds up to 1.0, u is the largest double
//                       below 1 (nextafter(1, 0)). One output per number; u in [0, 1). This is
//                       the value libstdc++'s std::generate_canonical<double, 53> gives for a
//                       64-bit engine, so a run built with GCC keeps the positions it had.
//   uniform_below(g, n): an integer in [0, n), n >= 1: draw x until x >= (2^64 - n) mod n
//                       (rejection removes the modulo bias), return x mod n.
//   shuffle(first, last, g): Fisher-Yates from the back: for i = n-1 down to 1,
//                       swap(v[i], v[uniform_below(g, i + 1)]).
#pragma once
#include <cmath>
#include <cstdint>
#include <iterator>
#include <random>
#include <utility>

namespace biodem {

inline double uniform01(std::mt19937_64& g) {
  const double u = static_cast<double>(g()) * 0x1.0p-64;
  return u < 1.0 ? u : std::nextafter(1.0, 0.0);
}

inline std::uint64_t uniform_below(std::mt19937_64& g, std::uint64_t n) {
  const std::uint64_t threshold = (0 - n) % n;  // (2^64 - n) mod n
  for (;;) {
    const std::uint64_t x = g();
    if (x >= threshold) return x % n;
  }
}

template <class RandomIt>
void shuffle(RandomIt first, RandomIt last, std::mt19937_64& g) {
  const auto n = static_cast<std::uint64_t>(std::distance(first, last));
  for (std::uint64_t i = n; i > 1; --i) {
    const std::uint64_t j = uniform_below(g, i);
    using std::swap;
    swap(first[static_cast<std::ptrdiff_t>(i - 1)], first[static_cast<std::ptrdiff_t>(j)]);
  }
}

}  // namespace biodem
