#include "core/sym_eigen.hpp"

#include <algorithm>
#include <array>
#include <cmath>

namespace biodem {

SymEigen sym_eigen(const Mat3& a_in) {
  Mat3 a = a_in;
  Mat3 v = Mat3::identity();
  for (int sweep = 0; sweep < 64; ++sweep) {
    const double off = a(0, 1) * a(0, 1) + a(0, 2) * a(0, 2) + a(1, 2) * a(1, 2);
    const double scale = a(0, 0) * a(0, 0) + a(1, 1) * a(1, 1) + a(2, 2) * a(2, 2);
    if (off <= 1e-30 * scale || off == 0.0) break;
    for (int p = 0; p < 2; ++p)
      for (int q = p + 1; q < 3; ++q) {
        if (a(p, q) == 0.0) continue;
        const double theta = (a(q, q) - a(p, p)) / (2.0 * a(p, q));
        const double t = (theta >= 0 ? 1.0 : -1.0) / (std::abs(theta) + std::sqrt(theta * theta + 1.0));
        const double c = 1.0 / std::sqrt(t * t + 1.0), s = t * c;
        for (int k = 0; k < 3; ++k) {  // a <- J^T a J
          const double akp = a(k, p), akq = a(k, q);
          a(k, p) = c * akp - s * akq;
          a(k, q) = s * akp + c * akq;
        }
        for (int k = 0; k < 3; ++k) {
          const double apk = a(p, k), aqk = a(q, k);
          a(p, k) = c * apk - s * aqk;
          a(q, k) = s * apk + c * aqk;
        }
        for (int k = 0; k < 3; ++k) {
          const double vkp = v(k, p), vkq = v(k, q);
          v(k, p) = c * vkp - s * vkq;
          v(k, q) = s * vkp + c * vkq;
        }
      }
  }
  std::array<int, 3> idx{0, 1, 2};
  std::sort(idx.begin(), idx.end(), [&](int i, int j) { return a(i, i) < a(j, j); });
  SymEigen r;
  for (int c = 0; c < 3; ++c) {
    r.values[c] = a(idx[c], idx[c]);
    for (int k = 0; k < 3; ++k) r.vectors(k, c) = v(k, idx[c]);
  }
  // Right-handed: third column = first x second.
  const Vec3 e0{r.vectors(0, 0), r.vectors(1, 0), r.vectors(2, 0)};
  const Vec3 e1{r.vectors(0, 1), r.vectors(1, 1), r.vectors(2, 1)};
  const Vec3 e2 = cross(e0, e1);
  for (int k = 0; k < 3; ++k) r.vectors(k, 2) = e2[k];
  return r;
}

}  // namespace biodem
