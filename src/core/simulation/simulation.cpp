#include "corde_sim/simulation/simulation.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iterator>
#include <stdexcept>

namespace corde {
namespace {
constexpr size_t kMaxEvents = 1000;  // not taken: the oldest go
}  // namespace

Command Command::goal(double time, const std::string& grasp, const Eigen::Isometry3d& pose,
                      double duration) {
  Command c;
  c.kind = Kind::kGoal;
  c.time = time;
  c.grasp = grasp;
  c.pose = pose;
  c.duration = duration;
  return c;
}

Command Command::sample(double time, const std::string& grasp, const Eigen::Isometry3d& pose,
                        double stamp) {
  Command c = goal(time, grasp, pose, 0.0);
  c.stamped = true;
  c.stamp = stamp;
  return c;
}

Command Command::wrench(double time, const std::string& grasp, const Vec3& force,
                        const Vec3& torque) {
  Command c;
  c.kind = Kind::kWrench;
  c.time = time;
  c.grasp = grasp;
  c.force = force;
  c.torque = torque;
  return c;
}

Command Command::twist_rate(double time, const std::string& grasp, double rate) {
  Command c;
  c.kind = Kind::kTwistRate;
  c.time = time;
  c.grasp = grasp;
  c.rate = rate;
  return c;
}

Command Command::grip(double time, const std::string& grasp, double force) {
  if (!(force >= 0.0) || !std::isfinite(force)) {
    char buf[120];
    std::snprintf(buf, sizeof buf, "grasp '%.40s': grip force %g N is not a finite force >= 0",
                  grasp.c_str(), force);
    throw std::invalid_argument(buf);
  }
  Command c;
  c.kind = Kind::kGripForce;
  c.time = time;
  c.grasp = grasp;
  c.grip_force = force;
  return c;
}

Command Command::release(double time, const std::string& grasp) {
  Command c;
  c.kind = Kind::kRelease;
  c.time = time;
  c.grasp = grasp;
  return c;
}

Simulation::Simulation(const GuardSettings& guard) : guard_(guard) {
  // The grasps, the scripts and the commands go back with the world; the holder limits and the
  // rest of the configuration are not in the snapshot.
  guard_.set_hooks(
      [this] {
        saved_grasps_ = grasps_;
        saved_scripts_ = scripts_;
        // The commands applied so far are in the saved state; the waiting ones stay.
        commands_.erase(commands_.begin(), commands_.begin() + static_cast<long>(next_));
        applied_high_ -= next_;
        next_ = 0;
      },
      [this] {
        grasps_ = saved_grasps_;
        scripts_ = saved_scripts_;
        next_ = 0;  // the commands since the snapshot are applied again, at the same steps
      });
  step_fn_ = [this](World* w) { step_once(w); };
}

void Simulation::install(World world) {
  own_ = std::move(world);
  attach(&own_);
}

void Simulation::attach(World* world) {
  world_ = world;
  grasps_.clear();
  saved_grasps_.clear();
  specs_.clear();
  drives_.clear();
  rods_.clear();
  scripts_.clear();
  saved_scripts_.clear();
  commands_.clear();
  next_ = applied_high_ = 0;
  queued_steps_ = 0;
  restart_guard();
}

void Simulation::restart_guard() {
  take_guard_events();
  // Commands applied before a failure went with the states the guard dropped: they are not
  // applied again to the state it kept.
  next_ = applied_high_;
  guard_.reset(*world_);  // snapshots the world, the grasps and the scripts
}

int Simulation::script_index(const std::string& name) const {
  for (size_t k = 0; k < specs_.size(); ++k)
    if (specs_[k].name == name) return static_cast<int>(k);
  return -1;
}

void Simulation::add_script(const GraspSpec& spec, ScriptDrive drive) {
  if (script_index(spec.name) >= 0)
    throw std::invalid_argument("grasp '" + spec.name + "' already has a script");
  int rod = -1;
  for (size_t r = 0; r < world_->rods().size(); ++r)
    if (world_->rods()[r].name() == spec.rod) rod = static_cast<int>(r);
  if (rod < 0)
    throw std::invalid_argument("grasp '" + spec.name + "': no rod named '" + spec.rod + "'");
  const GraspState* g = grasps_.find(spec.name);
  if (drive == ScriptDrive::kHolder && !(g && g->held))
    throw std::invalid_argument("grasp '" + spec.name + "' must be held to follow its script");
  // Holder scripts run in the order of their names (as the grasps do), exact ones as added.
  size_t at = specs_.size();
  if (drive == ScriptDrive::kHolder)
    for (size_t k = 0; k < specs_.size(); ++k)
      if (drives_[k] == ScriptDrive::kHolder && specs_[k].name > spec.name) {
        at = k;
        break;
      }
  specs_.insert(specs_.begin() + static_cast<long>(at), spec);
  drives_.insert(drives_.begin() + static_cast<long>(at), drive);
  rods_.insert(rods_.begin() + static_cast<long>(at), rod);
  scripts_.insert(scripts_.begin() + static_cast<long>(at), Script());
  const bool holds = grasp_holds(spec, world_->time(), 0.0);
  if (drive == ScriptDrive::kExact) {
    if (holds) take_hold_exact(world_, at);
  } else if (holds) {
    Script& s = scripts_[at];
    const Rod& r = world_->rods()[g->rod];
    s.start = segment_pose(r, g->grasp.segment);
    s.motion = holder_motion(spec, s.start);
    s.offset_inv = g->grasp.offset.inverse();
    s.holding = true;
  } else {
    grasps_.release(*world_, spec.name);  // it takes hold at grasp_time
  }
  mark_good();
}

bool Simulation::scripted(const std::string& name) const {
  const int k = script_index(name);
  return k >= 0 && scripts_[k].active;
}

bool Simulation::waiting_to_take_hold(const std::string& name) const {
  const int k = script_index(name);
  if (k < 0 || !scripts_[k].active) return false;
  if (drives_[k] == ScriptDrive::kExact) {
    if (scripts_[k].holding) return false;
  } else {
    const GraspState* g = grasps_.find(name);
    if (!g || g->held) return false;
  }
  // As grasp_holds(): the step starting within half a step of release_time lets go.
  return world_->time() < specs_[k].release_time - 0.5 * world_->time_step;
}

void Simulation::end_script_at(size_t k, double time, bool report) {
  Script& s = scripts_[k];
  if (!s.active) return;
  s.active = false;
  s.motion.reset();
  if (report) event(SimulationEvent::Kind::kScriptEnded, time, specs_[k].name);
}

bool Simulation::end_script(const std::string& name) {
  const int k = script_index(name);
  if (k < 0 || !scripts_[k].active) return false;
  end_script_at(k, world_->time(), false);
  mark_good();
  return true;
}

void Simulation::submit(Command c) {
  // A time already past is now: the queue stays in time order behind what was applied.
  // (After a rollback the commands up to applied_high_ are applied again: they are not waiting.)
  const size_t applied = std::max(next_, applied_high_);
  c.time = std::max(c.time, world_->time());
  if (applied > 0) c.time = std::max(c.time, commands_[applied - 1].time);
  auto same = [&](const Command& k) { return k.kind == c.kind && k.grasp == c.grasp; };
  const auto first_waiting = commands_.begin() + static_cast<long>(applied);
  auto at = std::upper_bound(first_waiting, commands_.end(), c.time,
                             [](double t, const Command& k) { return t < k.time; });
  // Commands waiting at the same time: a later one of the same kind for the same grasp replaces
  // the earlier (which would have been overridden at once), except that a goal of nonzero
  // duration after one of zero duration starts from it and is kept beside it; a goal of zero
  // duration replaces every goal there.
  auto same_time = at;
  while (same_time != first_waiting && std::prev(same_time)->time == c.time) --same_time;
  if (c.kind == Command::Kind::kGoal && !(c.duration > 0.0)) {
    at = commands_.erase(std::remove_if(same_time, at, same), at);
  } else {
    for (auto it = at; it != same_time;) {
      --it;
      if (!same(*it)) continue;
      if (c.kind != Command::Kind::kGoal || it->duration > 0.0) {
        *it = std::move(c);
        return;
      }
      break;
    }
  }
  commands_.insert(at, std::move(c));
}

void Simulation::apply_until(World* w, double t) {
  while (next_ < commands_.size() && commands_[next_].time <= t) {
    apply(w, commands_[next_], next_ >= applied_high_);
    ++next_;
    applied_high_ = std::max(applied_high_, next_);
  }
}

void Simulation::apply_due() { apply_until(world_, world_->time()); }

void Simulation::set_paused(bool paused) {
  paused_ = paused;
  if (!paused_) queued_steps_ = 0;
}

void Simulation::apply(World* w, const Command& c, bool first) {
  const int k = script_index(c.grasp);
  const bool holder_script = k >= 0 && drives_[k] == ScriptDrive::kHolder && scripts_[k].active;
  switch (c.kind) {
    case Command::Kind::kGoal: {
      const GraspState* g = grasps_.find(c.grasp);
      if (!g || !g->held) return;  // a script waiting to take hold keeps it
      if (holder_script) end_script_at(k, c.time, first);
      if (c.stamped)
        grasps_.add_sample(c.grasp, c.time, c.stamp, c.pose);
      else
        grasps_.set_goal(c.grasp, c.time, c.pose, c.duration);
      return;
    }
    case Command::Kind::kWrench:
      grasps_.set_wrench(*w, c.grasp, c.force, c.torque);
      return;
    case Command::Kind::kTwistRate:
      grasps_.set_twist_rate(c.grasp, c.rate);
      return;
    case Command::Kind::kGripForce:
      grasps_.set_grip_force(*w, c.grasp, c.grip_force);
      return;
    case Command::Kind::kRelease:
      if (holder_script) end_script_at(k, c.time, first);
      if (grasps_.release(*w, c.grasp) && first)
        event(SimulationEvent::Kind::kLetGo, w->time(), c.grasp);
      return;
  }
}

void Simulation::take_hold_exact(World* w, size_t k) {
  Script& s = scripts_[k];
  const GraspSpec& spec = specs_[k];
  Rod& rod = w->rods()[rods_[k]];
  s.start = segment_pose(rod, grasp_segment(rod, spec));
  s.grasp = make_grasp(rod, spec, s.start);
  s.motion = holder_motion(spec, s.start);
  s.holding = true;
  hold(rod, s.grasp, s.start);
}

void Simulation::drive_scripts(World* w, double t, double h) {
  for (size_t k = 0; k < scripts_.size(); ++k) {
    Script& s = scripts_[k];
    if (!s.active) continue;
    const GraspSpec& spec = specs_[k];
    const bool holds = grasp_holds(spec, t, h);
    if (drives_[k] == ScriptDrive::kExact) {
      if (holds && !s.holding) {
        take_hold_exact(w, k);
        event(SimulationEvent::Kind::kTookHold, t, spec.name);
      }
      if (!holds && s.holding) {
        release(w->rods()[rods_[k]], s.grasp);  // the segment keeps the velocity of the last step
        s.holding = false;
        event(SimulationEvent::Kind::kLetGo, t, spec.name);
      }
      if (s.holding && s.motion)
        hold(w->rods()[rods_[k]], s.grasp, s.motion->pose_at(t + h - spec.grasp_time, s.start));
      continue;
    }
    const GraspState* g = grasps_.find(spec.name);
    if (!g) continue;
    if (!holds) {
      // Before grasp_time, or let go at release_time: the segment keeps its velocity.
      if (g->held && grasps_.release(*w, spec.name))
        event(SimulationEvent::Kind::kLetGo, t, spec.name);
      s.holding = false;
      continue;
    }
    if (!g->held) {
      // Takes hold where the segment is now (nothing jumps); the keyframes start from there.
      int rod = -1, seg = -1;
      const std::string error = grasps_.check(*w, spec, &rod, &seg);
      if (!error.empty()) {
        if (!s.warned) event(SimulationEvent::Kind::kCannotHold, t, spec.name, error);
        s.warned = true;  // once until it takes hold
        continue;
      }
      s.start = segment_pose(w->rods()[rod], seg);
      grasps_.attach(*w, spec.name, s.start, nullptr, t);
      s.motion = holder_motion(spec, s.start);
      s.offset_inv = Eigen::Isometry3d::Identity();  // the holder is the segment's pose
      s.holding = true;
      s.warned = false;
      event(SimulationEvent::Kind::kTookHold, t, spec.name);
    }
    // Past the last keyframe the goal stays where the last call put it: the holder settles there
    // and costs nothing more.
    if (!s.motion || t - spec.grasp_time >= s.motion->end_time()) continue;
    const Eigen::Isometry3d pose = s.motion->pose_at(t + h - spec.grasp_time, s.start);
    grasps_.set_goal(spec.name, t, pose * s.offset_inv, h);
  }
}

void Simulation::step_once(World* w) {
  const double t = w->time(), h = w->time_step;  // the guard's, while it runs a halved step
  apply_until(w, t + 0.5 * h);
  if (!scripts_.empty()) drive_scripts(w, t, h);
  if (!grasps_.empty() && grasps_.before_step(*w, t, h, holder_limits_) > 0) report_stalls(*w, t);
  if (mover_) mover_(w, h);
  w->step();
  if (!grasps_.empty() && grasps_.after_step(*w, h) > 0) report_slid_out(t + h);
  if (observer_) observer_(*w);
}

bool Simulation::advance(long n) {
  if (paused_) {
    n = std::min(n, queued_steps_);
    queued_steps_ -= std::max(0L, n);
  }
  if (n <= 0) return !guard_.failed();
  const bool ok = guard_.step(world_, n, step_fn_);
  if (!guard_.settings().enabled) {
    // No snapshots: nothing goes back, so the applied commands go now.
    commands_.erase(commands_.begin(), commands_.begin() + static_cast<long>(next_));
    applied_high_ -= next_;
    next_ = 0;
  }
  take_guard_events();
  return ok;
}

bool Simulation::advance_until(double t) {
  const double h = world_->time_step;
  if (!(h > 0.0)) return !guard_.failed();
  const double n = std::floor((t - world_->time()) / h + 0.5);
  return advance(n > 0.0 ? static_cast<long>(std::min(n, 1e15)) : 0);
}

bool Simulation::settle() {
  const bool ok = !guard_.failed() && guard_.settle(world_, step_fn_);
  take_guard_events();
  return ok;
}

void Simulation::event(SimulationEvent::Kind kind, double time, const std::string& grasp,
                       std::string text) {
  if (events_.size() >= kMaxEvents) events_.erase(events_.begin());
  SimulationEvent e;
  e.kind = kind;
  e.time = time;
  e.grasp = grasp;
  e.text = std::move(text);
  events_.push_back(std::move(e));
}

void Simulation::report_stalls(const World& w, double t) {
  for (const auto& kv : grasps_.grasps()) {
    if (!kv.second.stall_new) continue;
    GraspState& g = *grasps_.find(kv.first);
    g.stall_new = false;
    const Rod& rod = w.rods()[g.rod];
    char text[400];
    std::snprintf(text, sizeof text,
                  "holder stalled at the strain limit: moving on would stretch rod '%s' to %.3g%% "
                  "between the held segment %d and node %d (held by a clamp or a grasp), beyond "
                  "its material's max_strain %.3g%%; the holder stays until sent within reach",
                  rod.name().c_str(), 100.0 * g.stall_strain, g.grasp.segment, g.stall_anchor,
                  100.0 * rod.section().max_strain);
    event(SimulationEvent::Kind::kStalled, t, kv.first, text);
  }
}

void Simulation::report_slid_out(double t) {
  for (const auto& kv : grasps_.grasps()) {
    const int out = kv.second.grip.slid_out;
    if (out == 0) continue;
    grasps_.find(kv.first)->grip.slid_out = 0;
    // Its script, if any, ends: it would take hold again where the cable fell.
    const int k = script_index(kv.first);
    if (k >= 0) end_script_at(static_cast<size_t>(k), t, false);
    event(SimulationEvent::Kind::kLetGo, t, kv.first,
          std::string("the cable slid out of the grip past its ") + (out < 0 ? "start" : "end"));
  }
}

void Simulation::take_guard_events() {
  if (guard_.events_total() == guard_events_seen_) return;
  for (const GuardEvent& g : guard_.events_since(guard_events_seen_)) {
    if (events_.size() >= kMaxEvents) events_.erase(events_.begin());
    SimulationEvent e;
    e.kind = SimulationEvent::Kind::kGuard;
    e.time = g.time;
    e.text = g.message();
    e.guard = g;
    events_.push_back(std::move(e));
  }
  guard_events_seen_ = guard_.events_total();
}

std::vector<SimulationEvent> Simulation::take_events() {
  take_guard_events();
  std::vector<SimulationEvent> out;
  out.swap(events_);
  return out;
}

}  // namespace corde
