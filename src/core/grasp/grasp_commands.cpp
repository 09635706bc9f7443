#include "corde_sim/grasp/grasp_commands.h"

#include <algorithm>
#include <iterator>

namespace corde {

void GraspCommandLog::keep(const Command& c) {
  // An input of the same kind for the same grasp at the same world time replaces the earlier one
  // (which then had no effect: a goal of a nonzero duration starts from the reference at its
  // time, which the next goal at that time starts from again; a wrench or a twist rate is a
  // setting). A goal of zero duration moves the reference to itself at once, so a goal of
  // nonzero duration after it starts from it: that pair is kept; a goal of zero duration replaces
  // any earlier one (where it starts from does not matter). Paused, or stopped by the guard, the
  // world time stands still while inputs keep arriving: the log keeps at most two goals per grasp
  // and one input of each other kind instead of growing.
  auto same = [&](const Command& k) { return k.kind == c.kind && k.name == c.name; };
  if (c.kind == Command::Kind::kGoal && !(c.duration > 0.0)) {
    // Every earlier goal at this time is superseded.
    auto first = commands_.end();
    while (first != commands_.begin() && std::prev(first)->time == c.time) --first;
    commands_.erase(std::remove_if(first, commands_.end(), same), commands_.end());
  } else {
    for (auto it = commands_.rbegin(); it != commands_.rend() && it->time == c.time; ++it) {
      if (!same(*it)) continue;
      // The latest input of this kind for this grasp: replaced, unless it is a goal of zero
      // duration that this one starts from.
      if (c.kind != Command::Kind::kGoal || it->duration > 0.0) {
        *it = c;
        next_ = commands_.size();
        return;
      }
      break;
    }
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
