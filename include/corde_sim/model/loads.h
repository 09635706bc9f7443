// Loads on a rod: forces on nodes and torques on segments, dead or follower, ramped in time, and
// their evaluation. Every part of the model that needs a load (the explicit forces, the rod
// system's energy and gradient, the implicit step's held loads, statics, the guard's work bound)
// evaluates it through these functions, so that what a load is is written once.
#pragma once

#include <algorithm>
#include <vector>

#include "corde_sim/math/types.h"

namespace corde {

// A force on a node or a torque on a segment, ramped linearly from zero to `value` over
// [t_start, t_start + ramp_time] and constant after (ramp_time 0: a step). A dead load keeps its
// direction in the world frame; a follower load is given in the body frame of a segment and turns
// with it (load_frame()).
struct Load {
  enum class Kind { kForce, kTorque };
  Kind kind = Kind::kForce;
  int index = 0;
  Vec3 value = Vec3::Zero();
  double t_start = 0.0;
  double ramp_time = 0.0;
  bool follower = false;

  // The ramp's factor at time t, in [0, 1].
  double scale(double t) const {
    if (t < t_start) return 0.0;
    if (ramp_time <= 0.0 || t >= t_start + ramp_time) return 1.0;
    return (t - t_start) / ramp_time;
  }
};

// In what follows k is the factor on the load's value: its ramp at the time, scale(t), times any
// continuation factor (statics ramps its loads from zero).

// The segment whose body frame a follower load turns with: a torque's own segment, a force on
// node i segment min(i, N - 1) of the N segments.
inline int load_frame(const Load& l, int num_segments) {
  return l.kind == Load::Kind::kTorque ? l.index : std::min(l.index, num_segments - 1);
}

// The load times k in the world frame: the force on its node (N) or the torque on its segment
// (N m). q: the segments' orientations (a follower load is turned by its frame's).
inline Vec3 load_world(const Load& l, double k, const std::vector<Quat>& q) {
  const Vec3 value = k * l.value;
  return l.follower ? Vec3(q[load_frame(l, static_cast<int>(q.size()))] * value) : value;
}

// A torque load times k in the body frame of its segment, whose orientation is q (N m).
inline Vec3 load_body_torque(const Load& l, double k, const Quat& q) {
  return k * (l.follower ? l.value : Vec3(q.conjugate() * l.value));
}

// The work of a dead load times k along d (J): a displacement of its node (a force) or a rotation
// vector of its segment in the world frame (a torque). A dead force's potential energy at node
// position x is -load_work(l, k, x); follower loads and torques have none (load_has_potential).
inline double load_work(const Load& l, double k, const Vec3& d) { return k * l.value.dot(d); }

// Whether the load has a potential energy: a dead force. A torque's work depends on the path of
// its segment's rotation, a follower's on the path of its frame.
inline bool load_has_potential(const Load& l) {
  return !l.follower && l.kind == Load::Kind::kForce;
}

// The magnitude of the load times k (N or N m), the same in every frame.
inline double load_magnitude(const Load& l, double k) { return l.value.norm() * k; }

}  // namespace corde
