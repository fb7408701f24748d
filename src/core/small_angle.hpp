// Sine and cosine of the small angles a time step turns a body by (|x| far below 1 rad), from
// their Taylor series: for |x| <= 1/16 the first omitted terms (x^11/11!, x^12/12!) are below
// 1e-20 relative, so the results are the library's to a few units in the last place, without a
// call. Larger angles take std::sin and std::cos.
#pragma once
#include <cmath>

#include "core/hd.hpp"

namespace biodem {

inline constexpr double kSmallAngleMax = 1.0 / 16.0;

BIODEM_HD inline void sincos_small_angle(double x, double& s, double& c) {
  const double x2 = x * x;
  if (!(x2 <= kSmallAngleMax * kSmallAngleMax)) {  // also NaN: the library propagates it
    s = std::sin(x);
    c = std::cos(x);
    return;
  }
  s = x * (1.0 + x2 * (-1.0 / 6.0 + x2 * (1.0 / 120.0 + x2 * (-1.0 / 5040.0 + x2 * (1.0 / 362880.0)))));
  c = 1.0 + x2 * (-0.5 + x2 * (1.0 / 24.0 + x2 * (-1.0 / 720.0 + x2 * (1.0 / 40320.0 + x2 * (-1.0 / 3628800.0)))));
}

}  // namespace biodem
