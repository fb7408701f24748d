// Fixed-point contact sums for the GPU engine's order-free family (BIODEM_GPU_SUMS=fixed,
// docs/gpu.md section 2).
//
// Each contact's force and torque are rounded to a grid (a power of two, `quantum`) and added to
// their sphere's sums as 64-bit integers. Integer addition is associative, so the sums do not
// depend on the order the contacts arrive in: the pass over the contacts may add them with atomic
// additions from any thread, on any number of threads, and the sums are the same bits.
// The rounding is the only difference from double sums: each contribution is off by at most half
// a quantum (round to nearest, ties to even), so a sphere's sum is off by at most
// (contributions / 2) quanta.
//
// The grid is chosen once per upload from the case (Engine::fixed_grid, scale_for): contributions
// up to a cap fit in 2^56 quanta; a contribution is refused (flagged, never wrapped) beyond
// `limit` quanta, where limit * (row capacity + walls) = 2^62, so no sum can overflow. For rows
// and walls of more than 64 slots the limit falls below 2^56 quanta, so below the cap (which is
// itself far above any force of a stable run: docs/gpu.md section 2).
#pragma once
#include <cmath>
#include <cstdint>

#include "core/hd.hpp"

namespace biodem::gpu::fixed {

/// The powers of two of a grid whose quantum fits contributions up to `cap` in 2^56 quanta:
/// scale = 2^(56 - e) with cap < 2^e (so cap * scale < 2^56), quantum = 1 / scale. Both exact.
/// A cap that is not a positive finite number (no contact can arise) gives the grid of cap 1.
inline double scale_for(double cap) {
  if (!(cap > 0.0) || !std::isfinite(cap)) cap = 1.0;
  int e = 0;
  (void)std::frexp(cap, &e);  // cap = m 2^e, 0.5 <= m < 1
  return std::ldexp(1.0, 56 - e);
}

/// The largest |x * scale| a contribution may have when a sphere has at most `slots`
/// contributions (row entries and walls): 2^62 / slots, so that no sum exceeds 2^62.
inline double limit_for(std::uint32_t slots) { return std::ldexp(1.0, 62) / static_cast<double>(slots ? slots : 1u); }

/// x in quanta, rounded to nearest (ties to even); `ok` is cleared when |x * scale| exceeds
/// `limit` or is not a number (then 0 is returned, nothing is added).
BIODEM_HD inline long long to_fixed(double x, double scale, double limit, bool& ok) {
  const double y = x * scale;  // exact (a power of two) unless it under- or overflows
  if (!(y <= limit && y >= -limit)) {
    ok = false;
    return 0;
  }
#if defined(__CUDA_ARCH__)
  return __double2ll_rn(y);
#else
  return std::llrint(y);  // the default rounding mode: to nearest, ties to even
#endif
}

/// Quanta back to a double: rounded to nearest once (beyond 2^53 quanta), then times the
/// quantum (exact).
BIODEM_HD inline double from_fixed(long long v, double quantum) {
#if defined(__CUDA_ARCH__)
  return __ll2double_rn(v) * quantum;
#else
  return static_cast<double>(v) * quantum;
#endif
}

/// *p += v, atomically (relaxed: only the sum matters, read after the kernel).
BIODEM_HD inline void atomic_add(long long* p, long long v) {
#if defined(__CUDA_ARCH__)
  atomicAdd(reinterpret_cast<unsigned long long*>(p), static_cast<unsigned long long>(v));
#else
  __atomic_fetch_add(p, v, __ATOMIC_RELAXED);
#endif
}

}  // namespace biodem::gpu::fixed
