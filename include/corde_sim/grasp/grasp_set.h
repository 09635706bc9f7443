// The grasps on the rods of a world (no ROS): each holds one segment with a rigid holder whose
// motion is limited in speed and acceleration (holder.h), can twist the segment about its
// tangent, can push it with a wrench, and measures the wrench the rod exerts on the holder (what
// a force-torque sensor in the gripper would read).
//
// Per step: before_step() moves the holders (within the caller's limits) and drives the held
// segments, World::step() steps, after_step() accumulates the reactions. Every time argument is the
// world's own time (World::time()), which before_step() also gets.
#pragma once

#include <Eigen/Geometry>
#include <map>
#include <string>

#include "corde_sim/grasp/friction_grasp.h"
#include "corde_sim/grasp/grasp.h"
#include "corde_sim/grasp/holder.h"
#include "corde_sim/world/world.h"

namespace corde {

struct GraspState {
  GraspSpec spec;  // as requested (a resample turns a node place into the arc length below)
  Grasp grasp;     // rod name, segment, offset (segment pose in the holder frame)
  int rod = 0;     // index into World::rods()
  bool held = true;
  HolderMotion holder;
  double twist_rate = 0.0;                           // rad/s about the held segment's tangent
  double twist_angle = 0.0;                          // rad accumulated, in (-pi, pi]
  Vec3 force = Vec3::Zero(), torque = Vec3::Zero();  // applied wrench, world frame, at the midpoint
  double arc_length = 0.0;  // rest arc length of the grasped segment's midpoint (m)
  // A friction grasp's state (grip.on; GraspSpec::grip): sticking or slipping, the arc length at
  // the grip point, the slip velocity. A slipping grasp's `grasp.segment` is the segment under
  // its grip point, which changes as the cable slides.
  FrictionGrip grip;
  HolderClip clip;           // limits hit since the caller last cleared it
  bool hold_pending = true;  // the drives must be set again at the next step
  // The holder stalled at the material's strain limit (HolderLimits::stall_at_max_strain): its
  // last motion would have stretched the cable between the held segment and node `stall_anchor`
  // (a clamp or another grasp) to `stall_strain` (above max_strain), so it stays where it is,
  // its goal kept, taking only motions within reach; the stall ends when the held node is nearer
  // the anchor than `stall_distance` (where it stalled). `stall_new`: stalled since the caller
  // last cleared it.
  bool stalled = false, stall_new = false;
  double stall_strain = 0.0, stall_distance = 0.0;
  int stall_anchor = -1;
  // Reaction: force on the holder and torque about its origin, world frame, summed over steps.
  Vec3 reaction_force_sum = Vec3::Zero(), reaction_torque_sum = Vec3::Zero();
  long reaction_steps = 0;

  // The holder's pose with the twist turned in: holder * offset * Rz(angle) * offset^-1.
  Eigen::Isometry3d holder_pose() const;

  // The held nodes and the holder's origin at the start of the current step (the reaction's
  // moment arms).
  Vec3 x0[2] = {Vec3::Zero(), Vec3::Zero()}, origin0 = Vec3::Zero();
};

class GraspSet {
 public:
  // "" if the spec can be grasped in `world` (its rod exists, the place is on it, no boundary
  // condition holds the segment's nodes or orientation, and no other held grasp holds that
  // segment or a neighbour sharing one of its nodes, which would leave two holders driving one
  // node); otherwise why not. Sets *rod and *segment when it can.
  std::string check(const World& world, const GraspSpec& spec, int* rod, int* segment) const;

  // Grasps the spec with a holder at `holder` at time `now`. Without an offset the segment keeps
  // its pose relative to the holder (nothing moves). With one, the segment is held at
  // holder * offset: the holder starts where that puts the segment now and moves to `holder`
  // within the limits. A released grasp of the same name is replaced; a held one is an error.
  std::string add(World& world, const GraspSpec& spec, const Eigen::Isometry3d& holder,
                  const Eigen::Isometry3d* offset, double now);
  // Lets go; the wrench keeps acting on the rod. Returns false if no held grasp has that name.
  // (A friction grasp also lets go by itself when the cable slides out past an end: after_step.)
  bool release(World& world, const std::string& name);
  // Holds the grasp's segment again from a new holder pose: the offset is re-recorded (no offset)
  // or the holder glides there (an offset), as in add().
  void attach(World& world, const std::string& name, const Eigen::Isometry3d& holder,
              const Eigen::Isometry3d* offset, double now);
  void clear() { grasps_.clear(); }
  // Forgets a grasp (the caller's choice: one released, without a wrench, so the world is
  // unaffected). Returns whether it was there.
  bool erase(const std::string& name) { return grasps_.erase(name) > 0; }

  GraspState* find(const std::string& name);
  const GraspState* find(const std::string& name) const;
  const std::map<std::string, GraspState>& grasps() const { return grasps_; }
  bool empty() const { return grasps_.empty(); }

  // Inputs. Each ignores a name it does not hold.
  void set_goal(const std::string& name, double now, const Eigen::Isometry3d& pose,
                double duration);
  // A pose of a time-stamped stream (HolderMotion::add_sample); false when it is not taken.
  bool add_sample(const std::string& name, double now, double stamp, const Eigen::Isometry3d& pose);
  void set_wrench(World& world, const std::string& name, const Vec3& force, const Vec3& torque);
  void set_twist_rate(const std::string& name, double rate);
  // A friction grasp's grip force (N, finite and >= 0; the caller checks), from the next step.
  // False (nothing changes) for a name that is not a friction grasp.
  bool set_grip_force(World& world, const std::string& name, double force);
  // Every holder stops where it is (after the state was restored from a snapshot).
  void stop_all();

  // Around World::step() (from t to t + h), the holders moving within `limits`. The limits are
  // the caller's configuration, not part of the set: a set restored from a snapshot keeps
  // following the limits set since. With limits.stall_at_max_strain a holder whose motion over
  // the step would stretch the cable between its held segment and the nearest held node on
  // either side (any node drive: a clamp, another grasp, a driven node) beyond the rod's
  // max_strain (the straight distance over the rest arc length, or the segments' own strain in
  // between when larger, as around an obstacle), while lengthening that distance, stays where it
  // is instead (GraspState::stalled); motions that shorten it are taken. Returns how many holders
  // stalled in this step that had not been stalled. Allocates nothing.
  int before_step(World& world, double t, double h, const HolderLimits& limits);
  // Adds up the reactions of the step and moves the friction grasps on (friction_grasp.h): a
  // sticking one whose force along the cable exceeded mu N slides from the next step, a sliding
  // one whose slip stopped or turned sticks, and a sliding one follows its grip point to the next
  // segment or, past the rod's start or end, lets go (FrictionGrip::slid_out). Returns how many
  // grasps let go so. Allocates nothing once each rod's supports existed.
  int after_step(World& world, double h);

  // Mean reaction since the last call in the frame of the holder's current pose (holder_pose(),
  // the twist turned in): the force the rod exerts on the holder and its torque about the
  // holder's origin. False when no step was
  // taken since (nothing to report).
  bool take_reaction(const std::string& name, Vec3* force, Vec3* torque);
  // A friction grasp's mean slip velocity since the last call: the rate at which the rest arc
  // length at its grip point changed (m/s; negative: towards the rod's start). False when it is
  // not a friction grasp or no step was taken since.
  bool take_slip(const std::string& name, double* velocity);

  // After rod `rod` was resampled (its segment indices changed): every grasp on it holds the
  // segment at its place again, the holders where they are: `start` and `end` the new first and
  // last segments, an arc length the segment nearest the arc length asked for, a node the segment
  // nearest the old segment's midpoint (its material coordinate).
  void remake_on(World& world, int rod);

 private:
  // The rod's external forces from the grasps' wrenches and the slipping grasps' friction.
  void apply_wrenches(World& world, int rod);
  // A friction grasp's state after a step (after_step); true when it let go.
  bool step_grip(World& world, GraspState* g, double h);
  void stick(World& world, GraspState* g);
  // A sticking friction grasp's torsional state after a step (friction_grasp.h): starts turning
  // in the fingers past mu N r, sticks again when the turn stops. `a`: the fingers' axis (world).
  void step_turn(World& world, GraspState* g, const Vec3& a);
  std::map<std::string, GraspState> grasps_;
};

}  // namespace corde
