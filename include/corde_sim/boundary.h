// Boundary conditions and loads on nodes and segments of a rod.
#pragma once

#include "corde_sim/energy_terms.h"

namespace corde {

// Prescribed motion of one node. While active the node is kinematic: its position is set, not
// integrated, and its velocity is the one of the prescribed motion.
struct NodeDrive {
  enum class Kind { kFixed, kVelocity, kTarget };
  Kind kind = Kind::kFixed;
  int node = 0;
  Vec3 origin = Vec3::Zero();    // position at t_start (fixed position for kFixed)
  Vec3 velocity = Vec3::Zero();  // kVelocity: constant velocity (m/s)
  double t_start = 0.0;
  Vec3 target = Vec3::Zero();  // kTarget: where the caller wants the node at the end of the step
};

// Prescribed orientation of one segment (kinematic, like NodeDrive).
struct SegmentDrive {
  enum class Kind { kFixed, kSpin, kTarget };
  Kind kind = Kind::kFixed;
  int segment = 0;
  Quat origin = Quat::Identity();  // orientation at t_start
  double rate = 0.0;               // kSpin: rotation rate about the segment's own tangent (rad/s)
  double t_start = 0.0;
  Quat target = Quat::Identity();  // kTarget: orientation at the end of the step
};

// A force on a node or a torque on a segment, both in the world frame, ramped linearly from zero
// to `value` over [t_start, t_start + ramp_time] and constant after (ramp_time 0: a step).
struct Load {
  enum class Kind { kForce, kTorque };
  Kind kind = Kind::kForce;
  int index = 0;
  Vec3 value = Vec3::Zero();
  double t_start = 0.0;
  double ramp_time = 0.0;

  double scale(double t) const {
    if (t < t_start) return 0.0;
    if (ramp_time <= 0.0 || t >= t_start + ramp_time) return 1.0;
    return (t - t_start) / ramp_time;
  }
};

// A fixed frame beyond an end of the rod, joined to the end segment by a bending element of half
// a segment's rest length. With the end node fixed and the end segment free to rotate this is a
// clamp whose bending acts at the node, which removes most of the O(1/N) bias of freezing the
// whole end segment (docs/model.md, "Clamps").
struct GhostFrame {
  bool active = false;
  Quat frame = Quat::Identity();
  Vec3 uhat = Vec3::Zero();  // rest strain of the boundary element
};

// Drag of the surrounding air (or fluid) at rest, per unit length of rod, split into the
// components of the velocity normal and tangential to the rod: f = -(c_n v_n + c_t v_t) -
// (q_n |v_n| v_n + q_t |v_t| v_t) (N/m). From a fluid of density rho_f and a normal drag
// coefficient C_d on a cylinder of diameter 2r: q_n = rho_f C_d r (= 1/2 rho_f C_d 2r).
struct Drag {
  double linear_normal = 0.0;         // c_n (N s/m^2)
  double linear_tangential = 0.0;     // c_t (N s/m^2)
  double quadratic_normal = 0.0;      // q_n (N s^2/m^3)
  double quadratic_tangential = 0.0;  // q_t (N s^2/m^3)
  bool active() const {
    return linear_normal > 0.0 || linear_tangential > 0.0 || quadratic_normal > 0.0 ||
           quadratic_tangential > 0.0;
  }
};

}  // namespace corde
