// Holding a place on a rod with a rigid holder (an anchor or a gripper).
//
// A grasp takes one segment: its two nodes and, optionally, its orientation follow the holder
// rigidly. The segment's pose relative to the holder is recorded when grasping, so grasping
// never moves the rod; after that, hold() drives the segment to holder_pose * offset.
#pragma once

#include <Eigen/Geometry>
#include <cmath>
#include <memory>
#include <string>

#include "corde_sim/rod/motion.h"
#include "corde_sim/rod/rod.h"

namespace corde {

// How a grasp holds: rigidly (friction false, the default), or by friction (scene key grip):
// fingers pressing with `force` (N) hold the cable while the force along it stays within
// mu * force and let it slide through otherwise (friction_grasp.h).
struct GripSpec {
  bool friction = false;
  double force = 0.0;  // N, >= 0
  double mu = 0.0;     // >= 0
};

// A place on a rod that something holds.
struct GraspSpec {
  std::string name, rod;
  enum class Place { kStart, kEnd, kNode, kArcLength } place = Place::kEnd;
  double value = 0.0;            // node index or arc length (m) for kNode / kArcLength
  bool hold_orientation = true;  // hold the frame too (rotating the holder twists the rod)
  GripSpec grip;                 // rigid, or held by friction
  // Keyframed motion of the holder from where it takes hold (its pose then: segment_pose()), about
  // the holder's origin; null: the holder stays (corde_run) or follows its inputs (the node).
  std::shared_ptr<const Motion> motion;
  // When the grasp holds (scene keys grasp_time and release_time): it takes hold at grasp_time,
  // its holder at the segment's pose then, and lets go at release_time (the segment is free from
  // then on and keeps its velocity). `motion` runs in the time since grasp_time.
  double grasp_time = 0.0;         // s
  double release_time = INFINITY;  // s; INFINITY: never
  // The holder pose `motion` was read relative to (the segment as created): holder_motion()
  // rebases it on where a late grasp takes hold.
  Eigen::Isometry3d motion_reference = Eigen::Isometry3d::Identity();
};

struct Grasp {
  std::string name;
  std::string rod;
  int segment = 0;
  Eigen::Isometry3d offset = Eigen::Isometry3d::Identity();  // segment pose in the holder frame
  bool hold_orientation = true;
  // The distance at which hold() keeps the segment's nodes (m); 0: its rest length. A friction
  // grasp holds a segment at the length it has when it takes hold, so that nothing jumps.
  double length = 0.0;
};

// The segment a spec refers to: start -> 0, end -> N-1, node k -> min(k, N-1), arc length s ->
// the segment whose midpoint (along the rest lengths) is nearest to s. Throws
// std::out_of_range for a negative node index or a non-finite arc length.
int grasp_segment(const Rod& rod, const GraspSpec& spec);

// Whether the grasp holds during the step from t to t + h: from the step that starts nearest
// grasp_time up to the one that starts nearest release_time (within half a step, so that round-off
// in t does not move them). The stability guard's halved replays take hold and let go at the same
// instant as the first run only when the times are on the step grid; elsewhere the replay's
// nearest (halved) step may start up to half a step from the first run's. With h = 0: whether it
// holds at the instant t (statics).
bool grasp_holds(const GraspSpec& spec, double t, double h);

// The holder's keyframed motion for a grasp whose holder takes hold at `start` (null without
// keyframes): spec.motion when it holds from t = 0; for a later grasp the same keyframes with the
// world positions and orientations kept and the displacements and turns relative to `start` (turns
// about the tangent then). Its time is the time since grasp_time.
std::shared_ptr<const Motion> holder_motion(const GraspSpec& spec, const Eigen::Isometry3d& start);

// Pose of a segment: translation at its midpoint, rotation with the directors as columns.
Eigen::Isometry3d segment_pose(const Rod& rod, int segment);

// Moves the whole rod rigidly so that segment `segment`'s pose (segment_pose) becomes `pose`:
// positions and orientations, and the velocities with them (body-frame angular velocities are
// unchanged by a rigid motion). Places a cable's start shape at a gripper (the node's
// start_at_frame). Drives and constraints are not moved: the caller checks there are none.
void place_rod(Rod& rod, int segment, const Eigen::Isometry3d& pose);

// Records the segment's current pose relative to the holder.
Grasp make_grasp(const Rod& rod, const GraspSpec& spec, const Eigen::Isometry3d& holder_pose);

// Drives the grasped segment to holder_pose * offset by the end of the next step: its two nodes
// to midpoint -/+ (rest length, or grasp.length, / 2) d3 (NodeDrive kTarget) and, if
// hold_orientation, its orientation (SegmentDrive kTarget). Call before each step with the holder's
// pose at the end of that step; drives already present on those nodes or that segment are replaced.
// Allocates nothing once the drives exist.
void hold(Rod& rod, const Grasp& grasp, const Eigen::Isometry3d& holder_pose);

// Removes the grasp's target drives (others, e.g. a fixed clamp on a shared node, stay). The
// segment continues from its current position and from the velocity of the last held step.
void release(Rod& rod, const Grasp& grasp);

}  // namespace corde
