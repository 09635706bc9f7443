// Motion of a rigid holder (a gripper or an anchor) between the poses it is sent.
//
// Poses arrive at a few to a few hundred hertz while the rod steps at kilohertz. The holder
// follows a reference that moves from where the holder was to each new goal over the interval
// between inputs (one input of delay, no overshoot), or, for time-stamped poses (a controller's
// stream), the poses interpolated by their stamps (pose_timeline.h), and the holder itself tracks
// that reference
// within a speed and an acceleration limit, linear and angular: a pose 1 m away, or one sent at
// 10 kHz, becomes a bounded motion instead of a yank that the rod cannot follow.
#pragma once

#include <Eigen/Geometry>

#include "corde_sim/grasp/pose_timeline.h"

namespace corde {

struct HolderLimits {
  double max_speed = 2.0;                 // m/s
  double max_acceleration = 50.0;         // m/s^2
  double max_angular_speed = 20.0;        // rad/s
  double max_angular_acceleration = 1e3;  // rad/s^2
  // A holder stalls at its material's strain limit (GraspSet::before_step): a motion that would
  // stretch the cable beyond its material's max_strain towards the next held place along it (a
  // clamp, another grasp) is not taken, so that a goal out of reach cannot tear the cable. False:
  // the holder goes wherever it is sent.
  bool stall_at_max_strain = true;
};

// Which limits clipped the motion in one advance() and left the holder behind its reference by
// more than these.
constexpr double kReportedLag = 1e-3;         // m
constexpr double kReportedAngularLag = 1e-2;  // rad
struct HolderClip {
  bool speed = false, acceleration = false;
  bool any() const { return speed || acceleration; }
};

class HolderMotion {
 public:
  // Holds `pose` from now on, at rest.
  void reset(const Eigen::Isometry3d& pose);
  // A new goal at time `now`, reached by the reference `duration` seconds later (0: at once;
  // the limits then shape the motion).
  void set_goal(double now, const Eigen::Isometry3d& goal, double duration);
  // A pose of a stream for time `stamp`, received at time `now`: from now on the reference is
  // the stream's poses interpolated by their stamps, a little late (PoseTimeline), starting from
  // the reference at `now`. A set_goal(), reset() or stop() ends the stream. False (nothing
  // changes) for a stamp not later than the stream's newest, or not finite.
  bool add_sample(double now, double stamp, const Eigen::Isometry3d& pose);
  bool streaming() const { return streaming_; }
  const PoseTimeline& stream() const { return stream_; }
  // Moves the holder from time t to t + h, tracking the reference within the limits.
  HolderClip advance(double t, double h, const HolderLimits& limits);
  // Stops where the holder is: the goal becomes the current pose.
  void stop();
  // At rest where the holder is, the goal kept: the next advance() starts from rest towards it.
  void halt();

  const Eigen::Isometry3d& pose() const { return pose_; }
  const Eigen::Isometry3d& goal() const { return goal_; }
  const Eigen::Vector3d& velocity() const { return v_; }          // world frame
  const Eigen::Vector3d& angular_velocity() const { return w_; }  // world frame
  // Reference pose at time t (the interpolation between the inputs, before the limits).
  Eigen::Isometry3d reference(double t) const;
  // What advance() changes (without the goal, the reference or the stream): taken before a step
  // and restored to undo it.
  struct Kinematics {
    Eigen::Isometry3d pose;
    Eigen::Quaterniond q;
    Eigen::Vector3d v, w;
    bool settled;
    double cached_t;
    Eigen::Vector3d cached_p;
    Eigen::Quaterniond cached_q;
  };
  Kinematics kinematics() const {
    return {pose_, q_, v_, w_, settled_, cached_t_, cached_p_, cached_q_};
  }
  void restore(const Kinematics& k);
  // False once the holder rests at its goal (then advance() costs nothing and changes nothing).
  bool moving() const { return !settled_; }

 private:
  // The reference as a position and a unit quaternion.
  void reference(double t, Eigen::Vector3d* p, Eigen::Quaterniond* q) const;
  // True when the reference rests at the goal from time t on.
  bool reference_ended(double t) const {
    return streaming_ ? stream_.ended(t) : t >= t0_ + duration_;
  }
  void end_stream() {
    streaming_ = false;
    stream_.clear();
  }

  Eigen::Isometry3d pose_ = Eigen::Isometry3d::Identity();
  Eigen::Quaterniond q_ = Eigen::Quaterniond::Identity();  // pose_'s rotation
  Eigen::Vector3d v_ = Eigen::Vector3d::Zero(), w_ = Eigen::Vector3d::Zero();
  Eigen::Isometry3d goal_ = Eigen::Isometry3d::Identity();
  Eigen::Vector3d p_start_ = Eigen::Vector3d::Zero(), p_goal_ = Eigen::Vector3d::Zero();
  Eigen::Quaterniond q_start_ = Eigen::Quaterniond::Identity();
  Eigen::Quaterniond q_goal_ = Eigen::Quaterniond::Identity();
  double t0_ = 0.0, duration_ = 0.0;
  bool settled_ = true;
  // The reference at the end of the last step, which is the start of the next (t advances by h).
  double cached_t_ = -1e300;
  Eigen::Vector3d cached_p_ = Eigen::Vector3d::Zero();
  Eigen::Quaterniond cached_q_ = Eigen::Quaterniond::Identity();
  bool streaming_ = false;  // the reference is stream_'s
  PoseTimeline stream_;
};

}  // namespace corde
