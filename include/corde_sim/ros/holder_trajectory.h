// Motion of a grasp holder between pose inputs (no ROS). Inputs arrive at a few to a few hundred
// hertz while the rod steps at kilohertz: jumping to each new pose would kick the held segment,
// so the holder moves from where it is to the new goal over the interval between the last two
// inputs (one input of delay, no overshoot), and the node samples it once per substep.
#pragma once

#include <Eigen/Geometry>
#include <algorithm>

namespace corde_sim {

class HolderTrajectory {
 public:
  // Holds `pose` from now on.
  void reset(const Eigen::Isometry3d& pose) {
    start_ = goal_ = pose;
    t0_ = 0.0;
    duration_ = 0.0;
  }
  // A new goal at simulation time `now`, reached `duration` seconds later (0: at once).
  void set_goal(double now, const Eigen::Isometry3d& goal, double duration) {
    start_ = at(now);
    goal_ = goal;
    t0_ = now;
    duration_ = std::max(0.0, duration);
  }
  Eigen::Isometry3d at(double t) const {
    if (!(duration_ > 0.0) || t >= t0_ + duration_) return goal_;
    const double a = std::max(0.0, (t - t0_) / duration_);
    Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
    const Eigen::Quaterniond qa(start_.linear()), qb(goal_.linear());
    out.linear() = qa.slerp(a, qb).toRotationMatrix();
    out.translation() = (1.0 - a) * start_.translation() + a * goal_.translation();
    return out;
  }
  const Eigen::Isometry3d& goal() const { return goal_; }
  bool moving(double t) const { return duration_ > 0.0 && t < t0_ + duration_; }

 private:
  Eigen::Isometry3d start_ = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d goal_ = Eigen::Isometry3d::Identity();
  double t0_ = 0.0, duration_ = 0.0;
};

}  // namespace corde_sim
