// Boundary conditions and loads on nodes and segments of a rod.
#pragma once

#include <memory>

#include "corde_sim/model/element_energies.h"
#include "corde_sim/rod/motion.h"

namespace corde {

// Prescribed motion of one node. While active the node is kinematic: its position is set, not
// integrated, and its velocity is the one of the prescribed motion.
struct NodeDrive {
  enum class Kind { kFixed, kVelocity, kTarget, kMotion };
  Kind kind = Kind::kFixed;
  int node = 0;
  Vec3 origin = Vec3::Zero();    // position at t_start (fixed position for kFixed)
  Vec3 velocity = Vec3::Zero();  // kVelocity: constant velocity (m/s)
  double t_start = 0.0;
  Vec3 target = Vec3::Zero();  // kTarget: where the caller wants the node at the end of the step
  // kMotion: origin + the motion's displacement (and, about `pivot`, its rotation) at time t.
  std::shared_ptr<const Motion> motion = nullptr;
  Vec3 pivot = Vec3::Zero();
  // Output of each step: the force the drive exerted on the node (world, N), m dv/dt - f.
  Vec3 reaction = Vec3::Zero();
};

// Prescribed orientation of one segment (kinematic, like NodeDrive).
struct SegmentDrive {
  enum class Kind { kFixed, kSpin, kTarget, kMotion };
  Kind kind = Kind::kFixed;
  int segment = 0;
  Quat origin = Quat::Identity();  // orientation at t_start
  double rate = 0.0;               // kSpin: rotation rate about the segment's own tangent (rad/s)
  double t_start = 0.0;
  Quat target = Quat::Identity();                  // kTarget: orientation at the end of the step
  std::shared_ptr<const Motion> motion = nullptr;  // kMotion: the motion's rotation times origin
  // Output of each step: the torque the drive exerted on the segment (world, N m).
  Vec3 reaction = Vec3::Zero();
};

// A node that may move along a line or in a plane through `point` only. The node is integrated
// with every force on it; the step then removes the motion across the line or plane, so forces
// along the free directions (a tension on a sliding end) act and the others are carried.
struct NodeConstraint {
  enum class Kind { kLine, kPlane };
  Kind kind = Kind::kLine;
  int node = 0;
  Vec3 point = Vec3::Zero();
  Vec3 direction = Vec3::UnitX();  // unit: the line's direction, or the plane's normal
  // The line's or plane's own velocity (world, m/s), for a support that moves (a slipping grasp:
  // `point` is then where the line is at the step's end); zero: a fixed line or plane.
  Vec3 velocity = Vec3::Zero();
  Vec3 reaction = Vec3::Zero();  // output: the constraint force of the last step (world, N)
};

// A segment that may only rotate about one world axis through its start orientation, e.g. its
// own tangent (a clamp whose twist is free, loaded by a moment about it). Exact dynamics about
// an axis of symmetry of the section (the tangent, or any perpendicular to it).
struct SegmentConstraint {
  int segment = 0;
  Quat origin = Quat::Identity();  // orientation when constrained
  Vec3 axis = Vec3::UnitZ();       // unit, world frame
  Vec3 reaction = Vec3::Zero();    // output: the constraint torque of the last step (world, N m)
};

// A force on a node or a torque on a segment, ramped linearly from zero to `value` over
// [t_start, t_start + ramp_time] and constant after (ramp_time 0: a step). A dead load keeps its
// direction in the world frame; a follower load is given in the body frame of a segment and turns
// with it (a torque: its own segment; a force on node i: segment min(i, N - 1)).
struct Load {
  enum class Kind { kForce, kTorque };
  Kind kind = Kind::kForce;
  int index = 0;
  Vec3 value = Vec3::Zero();
  double t_start = 0.0;
  double ramp_time = 0.0;
  bool follower = false;

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
  // A moving clamp: frame = motion rotation * origin at each step's end (null: fixed).
  std::shared_ptr<const Motion> motion = nullptr;
  Quat origin = Quat::Identity();
  // Output of each step: the torque the ghost element exerted on the end segment (world, N m).
  Vec3 reaction = Vec3::Zero();
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

namespace corde {

// Where a drive puts its node or segment at time t (kTarget: at its target), and with which
// velocity (world frame; kTarget: zero, its velocity comes from the step). The one evaluation of
// drives that the step and statics share.
Vec3 drive_position(const NodeDrive& d, double t, Vec3* velocity = nullptr);
Quat drive_orientation(const SegmentDrive& d, double t, Vec3* angular_velocity = nullptr);
// A ghost frame's orientation at time t (its motion applied to its origin, or fixed).
Quat ghost_frame_at(const GhostFrame& g, double t);

}  // namespace corde
