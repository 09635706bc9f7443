// Checks of inputs from topics and services (no ROS): each returns an empty string when the
// input is usable, otherwise the reason, for a throttled warning or a service reply.
#pragma once

#include <Eigen/Geometry>
#include <cctype>
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

// Limits on what a client may ask (docs/ros_interface.md, "Limits").
constexpr size_t kMaxNameLength = 256;      // grasp, rod and frame names, configure keys
constexpr size_t kMaxEcho = 100;            // characters of an input a reply or log line repeats
constexpr size_t kMaxReply = 1000;          // characters of a service reply's message
constexpr int kMaxGrasps = 64;              // grasps listed at once (scene and ~grasp)
constexpr double kMaxStepSeconds = 0.1;     // wall time one step may take (configure, reset)
constexpr long kMaxQueuedSteps = 10000000;  // ~step requests waiting to run
constexpr double kStepCallSeconds = 0.5;    // wall time a ~step call steps before queueing the rest

// An input as a reply may repeat it: at most kMaxEcho characters, then how long it was.
inline std::string clip(const std::string& s) {
  if (s.size() <= kMaxEcho) return s;
  return s.substr(0, kMaxEcho) + "... (" + std::to_string(s.size()) + " characters)";
}

// A reply's message, bounded whatever it quotes.
inline std::string clip_reply(const std::string& s) {
  return s.size() <= kMaxReply ? s : s.substr(0, kMaxReply) + "... (truncated)";
}

// "" or why `s` cannot be a name of kind `what`: at most kMaxNameLength characters.
inline std::string check_name_length(const std::string& s, const char* what) {
  if (s.size() <= kMaxNameLength) return "";
  return std::string(what) + " '" + clip(s) + "' is longer than " + std::to_string(kMaxNameLength) +
         " characters";
}

// Characters of a tf frame id: a ROS graph name with its separators.
inline bool valid_frame_chars(const std::string& s) {
  for (char c : s)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '/' || c == '-' ||
          c == '.'))
      return false;
  return true;
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
