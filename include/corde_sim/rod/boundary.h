// Boundary conditions on nodes and segments of a rod (drives, constraints, ghost-frame clamps) and
// the one evaluation of a drive's state. Loads and drag are in model/loads.h and model/drag.h.
#pragma once

#include <memory>

#include "corde_sim/model/drag.h"
#include "corde_sim/model/element_energies.h"
#include "corde_sim/model/loads.h"
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

// Where a drive puts its node or segment at time t (kTarget: at its target), and with which
// velocity (world frame; kTarget: zero, its velocity comes from the step). The one evaluation of
// drives that the steps and statics share.
Vec3 drive_position(const NodeDrive& d, double t, Vec3* velocity = nullptr);
Quat drive_orientation(const SegmentDrive& d, double t, Vec3* angular_velocity = nullptr);
// drive_orientation() with the sign of `near` (q and -q are one rotation): a driven segment's
// orientation as the steps and statics set it, so that its turn from `near` is the short one.
Quat drive_orientation_near(const SegmentDrive& d, double t, const Quat& near,
                            Vec3* angular_velocity = nullptr);
// A ghost frame's orientation at time t (its motion applied to its origin, or fixed).
Quat ghost_frame_at(const GhostFrame& g, double t);

// A driven node at the end of a step of length h ending at t_end, from position x at its start:
// the drive's position and velocity, or for kTarget its target and the velocity that reaches it
// over the step.
struct DrivenNode {
  Vec3 position;
  Vec3 velocity;  // world frame
};
DrivenNode drive_state(const NodeDrive& d, double t_end, double h, const Vec3& x);

// A driven segment at the end of a step of length h ending at t_end, from orientation q at its
// start: the drive's orientation and angular velocity, or for kTarget its target (on q's
// hemisphere) and the angular velocity that turns q into it over the step.
struct DrivenSegment {
  Quat orientation;
  Vec3 angular_velocity;        // body frame of `orientation`
  Vec3 world_angular_velocity;  // world frame
};
DrivenSegment drive_state(const SegmentDrive& d, double t_end, double h, const Quat& q);

}  // namespace corde
