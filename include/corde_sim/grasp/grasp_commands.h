// Inputs to a grasp set (goals, wrenches, twist rates) kept since the stability guard's last
// snapshot, so that a rollback does not lose them. The guard puts the world and the grasps back
// to the snapshot and redoes the steps since; the inputs received in that window are applied
// again at the world time they were first applied, and the replayed run follows the same inputs
// as the first one did.
#pragma once

#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "corde_sim/grasp/grasp_set.h"

namespace corde {

class GraspCommandLog {
 public:
  // Applies the input to `grasps` now (world time `now`) and keeps it for a replay.
  void set_goal(GraspSet& grasps, const std::string& name, double now,
                const Eigen::Isometry3d& pose, double duration);
  void set_wrench(GraspSet& grasps, World& world, const std::string& name, const Vec3& force,
                  const Vec3& torque);
  void set_twist_rate(GraspSet& grasps, const World& world, const std::string& name, double rate);

  // At a snapshot: the inputs kept so far are in the saved state.
  void clear() {
    commands_.clear();
    next_ = 0;
  }
  // At a rollback: every kept input is due again.
  void rewind() { next_ = 0; }
  // Before a step from t: applies the kept inputs first applied by then (within half a step h,
  // for the halved steps of a replay that land on t up to round-off). Allocates nothing.
  void replay(GraspSet& grasps, World& world, double t, double h);

  size_t size() const { return commands_.size(); }
  size_t pending() const { return commands_.size() - next_; }

 private:
  struct Command {
    enum class Kind { kGoal, kWrench, kTwistRate };
    Kind kind = Kind::kGoal;
    double time = 0.0;
    std::string name;
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    double duration = 0.0;
    Vec3 force = Vec3::Zero(), torque = Vec3::Zero();
    double rate = 0.0;
  };
  void apply(GraspSet& grasps, World& world, const Command& c) const;
  void keep(const Command& c);

  std::vector<Command> commands_;
  size_t next_ = 0;  // the first not applied since the last rewind (all of them when not replaying)
};

}  // namespace corde
