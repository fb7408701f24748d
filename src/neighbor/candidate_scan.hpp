// The candidate scan of the neighbour-list build (neighbor/verlet_list.cpp): the spheres of one
// range of cell-ordered items that are list neighbours of sphere i (index above i, another body,
// centres closer than r_i + r_j + skin). Non-periodic ranges only (no image shift).
//
// Two implementations with the same arithmetic and the same result: a scalar loop (any CPU) and
// an AVX-512F one (candidate_scan_avx512.cpp, built for that instruction set, chosen at run time
// when the CPU has it): eight candidates per comparison, the kept ones packed with a compress.
#pragma once
#include <cstddef>
#include <cstdint>

namespace biodem::neighbor {

/// One entry of a row being built: the neighbour and its packed periodic image (0 here).
struct ListEntry {
  std::uint32_t j;
  std::int32_t image;
};

/// The cell-ordered arrays the scan reads (structure of arrays: contiguous loads).
struct ScanArrays {
  const std::uint32_t* item = nullptr;  // sphere index of each cell-ordered slot
  const double* x = nullptr;
  const double* y = nullptr;
  const double* z = nullptr;
  const double* r = nullptr;
  const std::uint32_t* body = nullptr;
};

/// Sphere i's side of the test.
struct ScanQuery {
  double x = 0.0, y = 0.0, z = 0.0, r = 0.0, skin = 0.0;
  std::uint32_t index = 0, body = 0;
};

/// The slot ranges [lo[r], hi[r]) of the cells around sphere i (at most 27).
struct ScanRanges {
  std::uint32_t lo[27], hi[27];
  int count = 0;
  std::uint32_t slots = 0;  // sum of the ranges' lengths
};

/// Writes the kept candidates of the ranges to out (image 0), range by range in slot order;
/// returns how many. out must have room for ranges.slots + 8 entries (the vector scan stores
/// whole vectors).
using ScanFn = std::size_t (*)(const ScanArrays& a, const ScanRanges& ranges, const ScanQuery& q, ListEntry* out);

std::size_t scan_candidates_scalar(const ScanArrays& a, const ScanRanges& ranges, const ScanQuery& q, ListEntry* out);
#if defined(BIODEM_X86_LANES)
std::size_t scan_candidates_avx512(const ScanArrays& a, const ScanRanges& ranges, const ScanQuery& q, ListEntry* out);
#endif

/// The AVX-512F scan when this build has it and the CPU runs it (and BIODEM_LIST_SCAN is not
/// "scalar"), else the scalar one.
ScanFn best_candidate_scan();
/// Overrides the choice (tests): true selects the scalar scan.
void force_scalar_candidate_scan(bool scalar);

}  // namespace biodem::neighbor
