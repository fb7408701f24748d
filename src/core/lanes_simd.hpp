// SIMD lanes for the shared force laws on the CPU (core/lanes.hpp): std::experimental::simd of
// doubles (the Parallelism TS 2, shipped with GCC's libstdc++). The width is the target's native
// one: 2 with the baseline x86-64 build (SSE2), 4 in a translation unit built with -mavx2, 8 with
// -mavx512f (src/sim/pair_pass_*.cpp). Not for nvcc.
#pragma once
#include <experimental/simd>

#include "core/lanes.hpp"

namespace biodem {

namespace stdx = std::experimental;

template <class T, class Abi>
struct LaneOps<stdx::simd<T, Abi>> {
  using V = stdx::simd<T, Abi>;
  static V abs(const V& x) {
    V r = x;
    stdx::where(x < T(0), r) = -x;  // as the scalar x < 0 ? -x : x
    return r;
  }
  static V select(const typename V::mask_type& c, const V& a, const V& b) {
    V r = b;
    stdx::where(c, r) = a;
    return r;
  }
};

}  // namespace biodem
