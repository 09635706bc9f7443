// Continuous motion of an obstacle that follows poses arriving now and then (a robot link's tf
// frame, 30 to 200 Hz): each new pose is reached at constant linear and angular velocity over
// the interval it came after, so the contact solver sees a surface that moves a little every
// step with the velocity it is given, instead of one that jumps centimetres between tf messages
// (a jump would push the cable's nodes deep inside). The price is one tf interval of delay (plus
// the jitter with which poses are picked up, at most max_lag).
// No ROS here.
#pragma once

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "corde_sim/contact/obstacle.h"

namespace corde_sim {

class ObstacleGlide {
 public:
  using Vec3 = Eigen::Vector3d;

  // Starts (or restarts) at `pose`, at rest.
  void reset(const Eigen::Isometry3d& pose) {
    pose_ = target_ = pose;
    v_.setZero();
    w_.setZero();
    remaining_ = 0.0;
  }

  // Glides from the current pose to `target` (seconds of simulation time), reaching it
  // `interval` after the end of the glide under way, or longer if that would exceed `max_speed`
  // (m/s) or `max_angular_speed` (rad/s). Returns false when the caps made it longer (the motion
  // was faster than them: a jump in tf). Timing the glide from the previous target's arrival,
  // not from now, keeps a steady link steady when its poses are picked up early (tf arrives
  // with jitter; restarting the interval from now moved a 1 m/s link at up to 2.4 m/s). At most
  // `max_lag` of the glide under way is carried over: a simulation slower than the poses speeds
  // the link up instead of falling ever further behind.
  bool glide_to(const Eigen::Isometry3d& target, double interval, double max_speed,
                double max_angular_speed, double max_lag) {
    const double carried = std::clamp(remaining_, 0.0, std::max(max_lag, 0.0));
    target_ = target;
    const Vec3 d = target.translation() - pose_.translation();
    const Eigen::AngleAxisd turn(Eigen::Matrix3d(target.linear() * pose_.linear().transpose()));
    const double angle = std::abs(turn.angle());
    const double needed = std::max(d.norm() / max_speed, angle / max_angular_speed);
    const double duration = std::max(carried + interval, needed);
    if (!(duration > 0.0)) {
      reset(target);  // no motion at all
      return true;
    }
    remaining_ = duration;
    v_ = d / duration;
    w_ = (turn.angle() / duration) * turn.axis();
    return needed <= (carried + interval) * (1.0 + 1e-9);
  }

  // The pose at the start of the next step and the mean velocity over it (world frame; angular
  // velocity about the obstacle's origin). The last step of a glide gets the fraction of the
  // velocity that reaches the target exactly.
  const Eigen::Isometry3d& pose() const { return pose_; }
  Vec3 step_linear_velocity(double h) const { return fraction(h) * v_; }
  Vec3 step_angular_velocity(double h) const { return fraction(h) * w_; }
  bool moving() const { return remaining_ > 0.0; }

  // Moves the pose on by one step of h seconds.
  void advance(double h) {
    if (remaining_ <= 0.0) return;
    if (remaining_ <= h) {
      reset(target_);
      return;
    }
    pose_.translation() += h * v_;
    const double a = h * w_.norm();
    if (a > 0.0) {
      Eigen::Matrix3d r = Eigen::AngleAxisd(a, w_.normalized()).toRotationMatrix() * pose_.linear();
      // Re-orthonormalise: many small rotations drift.
      pose_.linear() = Eigen::Quaterniond(r).normalized().toRotationMatrix();
    }
    remaining_ -= h;
  }

 private:
  double fraction(double h) const {
    if (remaining_ <= 0.0 || !(h > 0.0)) return 0.0;
    return std::min(1.0, remaining_ / h);
  }

  Eigen::Isometry3d pose_ = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d target_ = Eigen::Isometry3d::Identity();
  Vec3 v_ = Vec3::Zero(), w_ = Vec3::Zero();
  double remaining_ = 0.0;  // s of simulation time left in the glide
};

// One step h of the obstacle in slot `index` of `set` that `glide` moves: its pose and velocity
// while it glides; once it has arrived, at rest there until the next pose. `*velocity_given`
// records that the set holds a non-zero velocity for it.
inline void glide_step(corde::ObstacleSet* set, int index, ObstacleGlide* glide,
                       bool* velocity_given, double h) {
  if (glide->moving()) {
    set->set_pose(index, glide->pose(), glide->step_linear_velocity(h),
                  glide->step_angular_velocity(h));
    *velocity_given = true;
    glide->advance(h);
  } else if (*velocity_given) {
    set->set_pose(index, glide->pose(), corde::Vec3::Zero(), corde::Vec3::Zero());
    *velocity_given = false;
  }
}

}  // namespace corde_sim
