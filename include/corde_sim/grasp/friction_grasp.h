// A grasp that holds a cable by friction: fingers pressing with a grip force N hold the cable
// while the force along it stays within mu N, and let it slide through otherwise, with kinetic
// friction mu N against the slip (docs/model.md, "Friction grasps").
//
// Sticking, the grasp is a rigid grasp (grasp.h: hold()). Sliding, the two nodes of the segment
// under the grip point are constrained to the fingers' line (NodeConstraint kLine, moving with
// the holder) and the friction force acts on them as an external force; the grip point moves
// along the cable and the constrained segment follows it across segment boundaries. The state
// changes between steps from what the last step left (GraspSet::after_step): a sticking grasp
// whose reaction along the cable exceeded mu N slides from the next step, a sliding one whose slip
// stopped or turned sticks, so the model is the same under every integrator.
//
// Torsional friction: the fingers also hold the cable about its axis up to a torque mu N r (r the
// cable's radius). A sticking grasp that holds the orientation and whose drive held the segment
// about the fingers' axis with more than that turns in the fingers from the next step: its nodes
// stay held, its orientation may only turn about the axis (SegmentConstraint) against the kinetic
// friction torque mu N r, until the turn stops or reverses (it sticks again, the turned offset
// recorded) or the holder swings the axis (it sticks, held rigidly while it swings).
#pragma once

#include "corde_sim/grasp/grasp.h"
#include "corde_sim/rod/rod.h"

namespace corde {

// The state of a friction grasp (GraspState::grip), set from GraspSpec::grip when it takes hold.
struct FrictionGrip {
  bool on = false;     // a friction grasp (false: rigid)
  double force = 0.0;  // grip force N (N)
  double mu = 0.0;     // friction coefficient
  // The grip point and the fingers' axis in the holder frame (the grasped segment's midpoint and
  // tangent when it took hold).
  Vec3 point = Vec3::Zero(), axis = Vec3::UnitZ();
  bool slipping = false;
  double direction = 0.0;      // while slipping: +1 the cable slides along +axis past the holder
  double arc = 0.0;            // rest arc length of the cable at the grip point (m)
  double slip_velocity = 0.0;  // d arc / dt over the last step (m/s)
  double slip_sum = 0.0, slip_time = 0.0;  // arc slipped and time since GraspSet::take_slip
  Vec3 line_velocity = Vec3::Zero();       // the grip point's velocity over the step (world)
  // The cable slid out of the fingers past its start (-1) or end (+1) in the last step (then the
  // grasp let go); 0: it did not.
  int slid_out = 0;
  // Turning in the fingers (torsional slip, while not sliding): +1 the segment turns about +axis
  // relative to the holder; the torque limit mu N r with the cable's radius r (m).
  bool turning = false;
  double turn_direction = 0.0;
  double radius = 0.0;

  double limit() const { return mu * force; }  // the largest force along the cable held (N)
  double torque_limit() const { return mu * force * radius; }  // about the cable (N m)
  // The friction torque on the segment while it turns (world), for the fingers' axis `a` (world).
  Vec3 friction_torque(const Vec3& a) const {
    return turning ? Vec3(-turn_direction * torque_limit() * a) : Vec3::Zero();
  }
  // The friction force on the cable while slipping (world), for the fingers' axis `a` (world).
  Vec3 friction(const Vec3& a) const {
    return slipping ? Vec3(-direction * limit() * a) : Vec3::Zero();
  }
};

// Rest arc length of the cable where the plane through `point` normal to `axis` (world) cuts
// segment `segment`, by the fraction of the segment's projection on the axis; *fraction gets that
// fraction (outside [0, 1]: the point is past the segment's nodes).
double grip_arc(const Rod& rod, int segment, const Vec3& point, const Vec3& axis, double* fraction);

// Constrains the grasped segment's two nodes to the line through `point` along `axis` (world, the
// line where it is at the end of the next step, moving with `velocity`), replacing the grasp's
// own target drives on them and on the segment. Allocates nothing once the constraints existed.
void hold_sliding(Rod& rod, const Grasp& grasp, const Vec3& point, const Vec3& axis,
                  const Vec3& velocity);

// Lets the grasped segment turn about `axis` (world) only, from its current orientation: its
// orientation drive is replaced by a SegmentConstraint (torsional slip). Its nodes stay driven.
void hold_turning(Rod& rod, const Grasp& grasp, const Vec3& axis);

// Removes the constraint hold_turning() put on the grasped segment.
void release_turning(Rod& rod, const Grasp& grasp);

// Removes the line constraints hold_sliding() put on the grasped segment's nodes.
void release_sliding(Rod& rod, const Grasp& grasp);

// Whether node `node` carries a boundary condition (a drive or a constraint) other than the grasp
// on `segment` (whose nodes are segment and segment + 1).
bool node_taken(const Rod& rod, int node, int segment);

}  // namespace corde
