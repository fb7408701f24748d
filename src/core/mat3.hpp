// 3x3 matrix (row-major) for inertia tensors and rotations.
#pragma once
#include <array>
#include "core/vec3.hpp"

namespace biodem {

struct Mat3 {
  std::array<double, 9> m{};  // row-major

  static constexpr Mat3 zero() { return Mat3{}; }
  static constexpr Mat3 identity() {
    Mat3 r;
    r.m = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    return r;
  }
  static constexpr Mat3 diag(double a, double b, double c) {
    Mat3 r;
    r.m = {a, 0, 0, 0, b, 0, 0, 0, c};
    return r;
  }
  constexpr double& operator()(int r, int c) { return m[3 * r + c]; }
  constexpr double operator()(int r, int c) const { return m[3 * r + c]; }
};

constexpr Vec3 operator*(const Mat3& a, const Vec3& v) {
  return {a(0, 0) * v.x + a(0, 1) * v.y + a(0, 2) * v.z, a(1, 0) * v.x + a(1, 1) * v.y + a(1, 2) * v.z,
          a(2, 0) * v.x + a(2, 1) * v.y + a(2, 2) * v.z};
}
constexpr Mat3 operator*(const Mat3& a, const Mat3& b) {
  Mat3 r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      double s = 0.0;
      for (int k = 0; k < 3; ++k) s += a(i, k) * b(k, j);
      r(i, j) = s;
    }
  return r;
}
constexpr Mat3 operator+(const Mat3& a, const Mat3& b) {
  Mat3 r;
  for (int i = 0; i < 9; ++i) r.m[i] = a.m[i] + b.m[i];
  return r;
}
constexpr Mat3 operator*(double s, const Mat3& a) {
  Mat3 r;
  for (int i = 0; i < 9; ++i) r.m[i] = s * a.m[i];
  return r;
}
constexpr Mat3 transpose(const Mat3& a) {
  Mat3 r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r(i, j) = a(j, i);
  return r;
}
/// Outer product a b^T.
constexpr Mat3 outer(const Vec3& a, const Vec3& b) {
  Mat3 r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r(i, j) = a[i] * b[j];
  return r;
}

}  // namespace biodem
