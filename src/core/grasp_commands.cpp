#include "corde_sim/grasp_commands.h"

namespace corde {

void GraspCommandLog::keep(const Command& c) {
  // An input of the same kind for the same grasp at the same world time replaces the earlier one
  // (which then had no effect: a goal starts from the reference at its time, and a wrench or a
  // twist rate is a setting). Paused, or stopped by the guard, the world time stands still while
  // inputs keep arriving: the log stays at one input per grasp and kind instead of growing.
  for (auto it = commands_.rbegin(); it != commands_.rend() && it->time == c.time; ++it)
    if (it->kind == c.kind && it->name == c.name) {
      *it = c;
      next_ = commands_.size();
      return;
    }
  commands_.push_back(c);
  next_ = commands_.size();
}

void GraspCommandLog::set_goal(GraspSet& grasps, const std::string& name, double now,
                               const Eigen::Isometry3d& pose, double duration) {
  Command c;
  c.kind = Command::Kind::kGoal;
  c.time = now;
  c.name = name;
  c.pose = pose;
  c.duration = duration;
  grasps.set_goal(name, now, pose, duration);
  keep(c);
}

void GraspCommandLog::set_wrench(GraspSet& grasps, World& world, const std::string& name,
                                 const Vec3& force, const Vec3& torque) {
  Command c;
  c.kind = Command::Kind::kWrench;
  c.time = world.time();
  c.name = name;
  c.force = force;
  c.torque = torque;
  grasps.set_wrench(world, name, force, torque);
  keep(c);
}

void GraspCommandLog::set_twist_rate(GraspSet& grasps, const World& world, const std::string& name,
                                     double rate) {
  Command c;
  c.kind = Command::Kind::kTwistRate;
  c.time = world.time();
  c.name = name;
  c.rate = rate;
  grasps.set_twist_rate(name, rate);
  keep(c);
}

void GraspCommandLog::apply(GraspSet& grasps, World& world, const Command& c) const {
  switch (c.kind) {
    case Command::Kind::kGoal:
      grasps.set_goal(c.name, c.time, c.pose, c.duration);
      break;
    case Command::Kind::kWrench:
      grasps.set_wrench(world, c.name, c.force, c.torque);
      break;
    case Command::Kind::kTwistRate:
      grasps.set_twist_rate(c.name, c.rate);
      break;
  }
}

void GraspCommandLog::replay(GraspSet& grasps, World& world, double t, double h) {
  while (next_ < commands_.size() && commands_[next_].time <= t + 0.5 * h)
    apply(grasps, world, commands_[next_++]);
}

}  // namespace corde
