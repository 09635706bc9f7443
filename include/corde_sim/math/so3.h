// Rotations as rotation vectors: the exponential and logarithm maps between rotation vectors and
// unit quaternions, the cross-product (skew) matrix, and the right Jacobian of exp. One copy for
// the integrators, statics, contacts and grasps, so that every caller turns a rotation vector
// into the same quaternion.
//
// A rotation vector theta is the rotation by |theta| about theta / |theta|; its quaternion is
// exp(theta / 2) = (cos(|theta|/2), sin(|theta|/2) theta / |theta|).
#pragma once

#include <cmath>

#include "corde_sim/math/types.h"

namespace corde {
namespace so3 {

// The matrix [v]x with [v]x y = v x y.
inline Mat3 skew(const Vec3& v) {
  Mat3 m;
  m << 0.0, -v.z(), v.y(), v.z(), 0.0, -v.x(), -v.y(), v.x(), 0.0;
  return m;
}

// exp(theta / 2) by the library's sin and cos, at any angle (identity below 1e-300 rad).
inline Quat exp_exact(const Vec3& theta) {
  const double a = theta.norm();
  if (a < 1e-300) return Quat::Identity();
  return Quat(Eigen::AngleAxisd(a, theta / a));
}

// exp(theta / 2); below 0.2 rad by the Taylor series of cos and sin(x)/x of the half angle x to
// x^8, exact to round-off there and several times cheaper than sin and cos (the implicit step
// turns every segment by one in every Newton iteration, mostly by far less than 0.2 rad).
inline Quat exp(const Vec3& theta) {
  const double a2 = theta.squaredNorm();
  if (a2 < 0.04) {
    const double x2 = 0.25 * a2;
    const double c = 1.0 + x2 * (-1.0 / 2 + x2 * (1.0 / 24 + x2 * (-1.0 / 720 + x2 / 40320)));
    const double sx = 1.0 + x2 * (-1.0 / 6 + x2 * (1.0 / 120 + x2 * (-1.0 / 5040 + x2 / 362880)));
    const Vec3 v = (0.5 * sx) * theta;
    return Quat(c, v.x(), v.y(), v.z());
  }
  const double a = std::sqrt(a2);
  return Quat(Eigen::AngleAxisd(a, theta / a));
}

// Rotation vector of the unit quaternion r, the shorter way round (|result| <= pi), by atan2 at
// any angle (2 vec(r) below 1e-300).
inline Vec3 log_exact(const Quat& r) {
  double w = r.w();
  Vec3 v = r.vec();
  if (w < 0.0) {
    w = -w;
    v = -v;
  }
  const double n = v.norm();
  if (n < 1e-300) return 2.0 * v;
  return (2.0 * std::atan2(n, w) / n) * v;
}

// Rotation vector of the unit quaternion r, the shorter way round; for half angles with
// tan < 0.1 by the series of 2 atan(t) / t to t^12 (cheap and exact to round-off there).
inline Vec3 log(const Quat& r) {
  const double s = r.w() < 0.0 ? -1.0 : 1.0;
  const Vec3 v = s * r.vec();
  const double n2 = v.squaredNorm(), w = s * r.w();
  if (n2 < 0.01 * w * w) {
    const double t2 = n2 / (w * w);
    const double f =
        1.0 + t2 * (-1.0 / 3 +
                    t2 * (1.0 / 5 + t2 * (-1.0 / 7 + t2 * (1.0 / 9 + t2 * (-1.0 / 11 + t2 / 13)))));
    return (2.0 * f / w) * v;
  }
  const double n = std::sqrt(n2);
  if (n < 1e-300) return Vec3::Zero();
  return (2.0 * std::atan2(n, w) / n) * v;
}

// J_r(theta), the right Jacobian of exp: exp(theta + d) = exp(theta) exp(J_r(theta) d) to first
// order in d (as rotations).
inline Mat3 right_jacobian(const Vec3& theta) {
  const double a = theta.norm();
  const double c1 = a < 1e-4 ? 0.5 - a * a / 24.0 : (1.0 - std::cos(a)) / (a * a);
  const double c2 = a < 1e-4 ? 1.0 / 6.0 - a * a / 120.0 : (a - std::sin(a)) / (a * a * a);
  const Mat3 k = skew(theta);
  return Mat3::Identity() - c1 * k + c2 * k * k;
}

// J_r^-1(theta)^T y = y - theta x y / 2 + c theta x (theta x y), c = 1/a^2 - (1 + cos a) /
// (2 a sin a) for a = |theta| (below 0.3 its series to a^8, free of the formula's cancellation):
// the gradient of f(log(exp(theta) exp(delta))) at delta = 0 when y = df/dtheta.
inline Vec3 inv_right_jacobian_t(const Vec3& theta, const Vec3& y) {
  const double a2 = theta.squaredNorm();
  double c;
  if (a2 < 0.09) {
    c = 1.0 / 12 + a2 * (1.0 / 720 + a2 * (1.0 / 30240 + a2 * (1.0 / 1209600 + a2 / 47900160)));
  } else {
    const double a = std::sqrt(a2);
    c = 1.0 / a2 - (1.0 + std::cos(a)) / (2.0 * a * std::sin(a));
  }
  return y - 0.5 * theta.cross(y) + c * theta.cross(theta.cross(y));
}

}  // namespace so3
}  // namespace corde
