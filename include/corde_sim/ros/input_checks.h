// Checks of inputs from topics and services (no ROS): each returns an empty string when the
// input is usable, otherwise the reason, for a throttled warning or a service reply.
#pragma once

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <string>

namespace corde_sim {

// A number for messages: six significant digits, no trailing zeros (%g).
inline std::string num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%g", v);
  return buf;
}

// Quaternions whose norm is off by more than this are rejected; closer ones are normalised.
constexpr double kQuaternionNormTolerance = 1e-3;

inline std::string check_vector(const Eigen::Vector3d& v, const char* what) {
  if (!v.allFinite()) return std::string(what) + " is not finite";
  return "";
}

// Normalises *q in place when it is within tolerance of unit length.
inline std::string check_pose(const Eigen::Vector3d& p, Eigen::Quaterniond* q) {
  if (!p.allFinite()) return "position is not finite";
  if (!q->coeffs().allFinite()) return "orientation is not finite";
  const double n = q->norm();
  if (std::abs(n - 1.0) > kQuaternionNormTolerance)
    return "orientation is not a unit quaternion (norm " + num(n) + ")";
  q->normalize();
  return "";
}

// age = now - stamp (s). A zero stamp means "now" and is accepted.
inline std::string check_stamp_age(double age, bool stamp_is_zero, double max_age) {
  if (stamp_is_zero) return "";
  if (!std::isfinite(age)) return "stamp is not finite";
  if (age > max_age) return "stamp is " + num(age) + " s old (max_pose_age " + num(max_age) + " s)";
  if (age < -max_age)
    return "stamp is " + num(-age) + " s in the future (max_pose_age " + num(max_age) + " s)";
  return "";
}

}  // namespace corde_sim
