#include "neighbor/candidate_scan.hpp"

#include <atomic>
#include <cstdlib>
#include <cstring>
#include <string>

#include "core/error.hpp"

namespace biodem::neighbor {

std::size_t scan_candidates_scalar(const ScanArrays& a, const ScanRanges& ranges, const ScanQuery& q, ListEntry* out) {
  std::size_t u = 0;
  for (int r = 0; r < ranges.count; ++r)
    for (std::uint32_t p = ranges.lo[r]; p < ranges.hi[r]; ++p) {
      const std::uint32_t j = a.item[p];
      if (j <= q.index || a.body[p] == q.body) continue;
      const double dx = q.x - a.x[p], dy = q.y - a.y[p], dz = q.z - a.z[p];
      const double cut = q.r + a.r[p] + q.skin;
      if (dx * dx + dy * dy + dz * dz < cut * cut) out[u++] = {j, 0};
    }
  return u;
}

namespace {
std::atomic<bool> g_force_scalar{false};

bool cpu_has_avx512() {
#if defined(BIODEM_X86_LANES)
  const bool has = __builtin_cpu_supports("avx512f");
#else
  const bool has = false;
#endif
  const char* v = std::getenv("BIODEM_LIST_SCAN");
  if (v == nullptr || *v == '\0') return has;
  if (std::strcmp(v, "scalar") == 0) return false;
  if (std::strcmp(v, "avx512") != 0)
    throw Error("BIODEM_LIST_SCAN = '" + std::string(v) + "': expected scalar or avx512");
  if (!has) throw Error("BIODEM_LIST_SCAN = avx512: this CPU or build has no AVX-512F candidate scan");
  return true;
}
}  // namespace

ScanFn best_candidate_scan() {
  static const bool avx512 = cpu_has_avx512();
#if defined(BIODEM_X86_LANES)
  if (avx512 && !g_force_scalar.load(std::memory_order_relaxed)) return &scan_candidates_avx512;
#endif
  (void)avx512;
  return &scan_candidates_scalar;
}

void force_scalar_candidate_scan(bool scalar) { g_force_scalar.store(scalar, std::memory_order_relaxed); }

}  // namespace biodem::neighbor
