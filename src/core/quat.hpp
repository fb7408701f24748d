// Unit quaternion (w, x, y, z) for rigid-body orientation: body frame -> lab frame.
#pragma once
#include "core/hd.hpp"
#include <cmath>
#include "core/mat3.hpp"
#include "core/vec3.hpp"

namespace biodem {

struct Quat {
  double w = 1.0, x = 0.0, y = 0.0, z = 0.0;
};

constexpr Quat operator*(const Quat& a, const Quat& b) {
  return {a.w * b.w - a.x * b.x - a.y * b.y - a.z * b.z, a.w * b.x + a.x * b.w + a.y * b.z - a.z * b.y,
          a.w * b.y - a.x * b.z + a.y * b.w + a.z * b.x, a.w * b.z + a.x * b.y - a.y * b.x + a.z * b.w};
}
constexpr Quat conj(const Quat& q) { return {q.w, -q.x, -q.y, -q.z}; }
BIODEM_HD inline Quat normalized(const Quat& q) {
  const double n = std::sqrt(q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z);
  return {q.w / n, q.x / n, q.y / n, q.z / n};
}
/// Rotation of angle |v|*... : quaternion for a rotation by `angle_rad` about unit `axis`.
BIODEM_HD inline Quat axis_angle(const Vec3& axis, double angle_rad) {
  const double h = 0.5 * angle_rad, s = std::sin(h);
  return {std::cos(h), axis.x * s, axis.y * s, axis.z * s};
}
/// Rotation matrix R such that v_lab = R v_body.
constexpr Mat3 to_matrix(const Quat& q) {
  const double ww = q.w * q.w, xx = q.x * q.x, yy = q.y * q.y, zz = q.z * q.z;
  const double xy = q.x * q.y, xz = q.x * q.z, yz = q.y * q.z, wx = q.w * q.x, wy = q.w * q.y,
               wz = q.w * q.z;
  Mat3 r;
  r.m = {ww + xx - yy - zz, 2 * (xy - wz),     2 * (xz + wy),  //
         2 * (xy + wz),     ww - xx + yy - zz, 2 * (yz - wx),  //
         2 * (xz - wy),     2 * (yz + wx),     ww - xx - yy + zz};
  return r;
}
BIODEM_HD inline Vec3 rotate(const Quat& q, const Vec3& v) { return to_matrix(q) * v; }
BIODEM_HD inline Vec3 rotate_inverse(const Quat& q, const Vec3& v) { return transpose(to_matrix(q)) * v; }

}  // namespace biodem

namespace biodem {
/// Quaternion of a proper rotation matrix (Shepperd's method, numerically stable branch choice).
BIODEM_HD inline Quat from_matrix(const Mat3& r) {
  const double tr = r(0, 0) + r(1, 1) + r(2, 2);
  Quat q;
  if (tr > 0.0) {
    const double s = 2.0 * std::sqrt(1.0 + tr);
    q = {0.25 * s, (r(2, 1) - r(1, 2)) / s, (r(0, 2) - r(2, 0)) / s, (r(1, 0) - r(0, 1)) / s};
  } else if (r(0, 0) > r(1, 1) && r(0, 0) > r(2, 2)) {
    const double s = 2.0 * std::sqrt(1.0 + r(0, 0) - r(1, 1) - r(2, 2));
    q = {(r(2, 1) - r(1, 2)) / s, 0.25 * s, (r(0, 1) + r(1, 0)) / s, (r(0, 2) + r(2, 0)) / s};
  } else if (r(1, 1) > r(2, 2)) {
    const double s = 2.0 * std::sqrt(1.0 + r(1, 1) - r(0, 0) - r(2, 2));
    q = {(r(0, 2) - r(2, 0)) / s, (r(0, 1) + r(1, 0)) / s, 0.25 * s, (r(1, 2) + r(2, 1)) / s};
  } else {
    const double s = 2.0 * std::sqrt(1.0 + r(2, 2) - r(0, 0) - r(1, 1));
    q = {(r(1, 0) - r(0, 1)) / s, (r(0, 2) + r(2, 0)) / s, (r(1, 2) + r(2, 1)) / s, 0.25 * s};
  }
  return normalized(q);
}
}  // namespace biodem
