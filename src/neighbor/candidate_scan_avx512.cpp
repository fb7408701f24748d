// The AVX-512F candidate scan (neighbor/candidate_scan.hpp). Built with -mavx512f and without
// FMA contraction (CMakeLists.txt): the distance and cut-off are the scalar scan's IEEE
// operations in the same order, so both keep the same candidates. Only intrinsics and this one
// function: no inline function of the baseline build is compiled here. Compiled without
// -mavx512f (targets in other directories that list the core's sources, e.g. the sanitizer
// replays: the file's options are set in the top directory only), it is empty; those targets
// do not define BIODEM_X86_LANES, so nothing refers to it.
#include "neighbor/candidate_scan.hpp"

#if defined(__AVX512F__)
#include <immintrin.h>

static_assert(sizeof(biodem::neighbor::ListEntry) == 8, "a ListEntry is one 64-bit lane");

namespace biodem::neighbor {

std::size_t scan_candidates_avx512(const ScanArrays& a, const ScanRanges& ranges, const ScanQuery& q, ListEntry* out) {
  const __m512d xi = _mm512_set1_pd(q.x), yi = _mm512_set1_pd(q.y), zi = _mm512_set1_pd(q.z);
  const __m512d ri = _mm512_set1_pd(q.r), skin = _mm512_set1_pd(q.skin);
  const __m512i ii = _mm512_set1_epi64(q.index), bi = _mm512_set1_epi64(q.body);
  std::size_t u = 0;
  for (int r = 0; r < ranges.count; ++r) {
  const std::uint32_t lo = ranges.lo[r], hi = ranges.hi[r];
  for (std::uint32_t p = lo; p < hi; p += 8) {
    const std::uint32_t left = hi - p;
    const __mmask8 valid = left >= 8 ? static_cast<__mmask8>(0xFF) : static_cast<__mmask8>((1u << left) - 1u);
    // Masked-out lanes are not read (no access past hi).
    const __m512i j = _mm512_cvtepu32_epi64(_mm512_castsi512_si256(_mm512_maskz_loadu_epi32(valid, a.item + p)));
    const __m512i b = _mm512_cvtepu32_epi64(_mm512_castsi512_si256(_mm512_maskz_loadu_epi32(valid, a.body + p)));
    const __m512d dx = _mm512_sub_pd(xi, _mm512_maskz_loadu_pd(valid, a.x + p));
    const __m512d dy = _mm512_sub_pd(yi, _mm512_maskz_loadu_pd(valid, a.y + p));
    const __m512d dz = _mm512_sub_pd(zi, _mm512_maskz_loadu_pd(valid, a.z + p));
    const __m512d d2 = _mm512_add_pd(_mm512_add_pd(_mm512_mul_pd(dx, dx), _mm512_mul_pd(dy, dy)), _mm512_mul_pd(dz, dz));
    const __m512d cut = _mm512_add_pd(_mm512_add_pd(ri, _mm512_maskz_loadu_pd(valid, a.r + p)), skin);
    __mmask8 keep = _mm512_mask_cmp_pd_mask(valid, d2, _mm512_mul_pd(cut, cut), _CMP_LT_OQ);
    keep &= _mm512_cmpgt_epu64_mask(j, ii) & _mm512_cmpneq_epu64_mask(b, bi);
    // Each 64-bit lane is a ListEntry {j, 0} (little-endian: j in the low half).
    _mm512_storeu_si512(out + u, _mm512_maskz_compress_epi64(keep, j));
    u += static_cast<std::size_t>(__builtin_popcount(keep));
  }
  }
  return u;
}

}  // namespace biodem::neighbor

#endif  // __AVX512F__
