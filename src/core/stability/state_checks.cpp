#include "corde_sim/stability/state_checks.h"

#include <cmath>
#include <cstdio>

namespace corde {
namespace {

std::string fmt(const char* f, const std::string& rod, int i, double v) {
  char buf[160];
  std::snprintf(buf, sizeof(buf), f, rod.c_str(), i, v);
  return buf;
}

}  // namespace

std::string validity_problem(const World& world, const ValidityLimits& limits) {
  for (const Rod& rod : world.rods()) {
    const std::string& name = rod.name();
    for (int i = 0; i < rod.num_nodes(); ++i) {
      if (!rod.positions()[i].allFinite() || !rod.velocities()[i].allFinite())
        return "rod '" + name + "': node " + std::to_string(i) + " is not finite";
      const double v = rod.velocities()[i].norm();
      if (v > limits.max_speed) return fmt("rod '%s': node %d moves at %g m/s", name, i, v);
    }
    for (int s = 0; s < rod.num_segments(); ++s) {
      const Quat& q = rod.orientations()[s];
      if (!q.coeffs().allFinite() || !rod.angular_velocities()[s].allFinite())
        return "rod '" + name + "': segment " + std::to_string(s) + " is not finite";
      const double n = q.norm();
      if (std::abs(n - 1.0) > limits.quaternion_tolerance)
        return fmt("rod '%s': segment %d has a quaternion of norm %g", name, s, n);
      const double w = rod.angular_velocities()[s].norm();
      if (w > limits.max_angular_speed)
        return fmt("rod '%s': segment %d spins at %g rad/s", name, s, w);
    }
  }
  return "";
}

}  // namespace corde
