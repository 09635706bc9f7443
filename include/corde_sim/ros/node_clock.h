// The node's time model (no ROS): how many steps are due, and the one mapping between the node's
// simulation time and ROS time, in each of the three time sources:
//
//  - kPublishClock (~publish_clock true): this node is the time source; ROS time = simulation
//    time; steps paced on the steady wall clock by the real-time factor (0: as fast as possible).
//  - kExternalClock (/use_sim_time true, ~publish_clock false): another node's /clock paces the
//    steps one to one (the real-time factor is not used); nothing runs before a nonzero /clock;
//    a state is never stamped ahead of the clock, but for a state changed by a service (one step
//    after the previous one) or ~step's steps while the clock stands still (so that a changed
//    state always gets a later stamp);
//    a clock going back (a bag looping) or leaping forward (more than kJumpSeconds beyond the
//    wall time since it was last observed)
//    re-anchors the mapping instead of running the gap.
//  - kWall (default): steps paced on the steady wall clock by the real-time factor; a state is
//    stamped with the ROS (wall) time at which it was due. When the node drops a backlog, runs
//    unpaced (factor 0) or runs ~step's steps while paused, the mapping is re-anchored at the
//    current ROS time, so stamps never drift from ROS time and are never in the future.
//
// The mapping is affine: stamp(t) = ros_anchor + (t - sim_anchor) / rate, rate = the real-time
// factor (kWall paced), the measured one (kWall unpaced, where every batch re-anchors, so the
// current state is stamped at the anchor), or 1. ROS times are integer nanoseconds here, as in
// ros::Time, so that stamps near 1.7e9 s keep their 1 ns.
#pragma once

#include <cmath>
#include <cstdint>

#include "corde_sim/ros/pacer.h"

namespace corde_sim {

enum class TimeSource { kPublishClock, kExternalClock, kWall };

class NodeClock {
 public:
  // A /clock moving forward by more than this (s) beyond the wall time elapsed since the last
  // observe() is a jump, not a backlog to catch up (a stalled loop's clock moved as much as the
  // wall time).
  static constexpr double kJumpSeconds = 1.0;
  // A /clock moving back by more than this (s) is a jump back (small reorderings are ignored).
  static constexpr double kBackTolerance = 1e-3;

  // Starts at simulation time `sim`, steady wall time `wall` (s) and ROS time `ros_ns`. With an
  // external clock the mapping waits for the first nonzero ROS time (ready() false until then).
  void start(TimeSource source, double factor, double sim, double wall, std::int64_t ros_ns);
  TimeSource source() const { return source_; }
  // False while following an external /clock that has not shown a nonzero time yet.
  bool ready() const { return ready_; }
  // A new real-time factor (dynamic_reconfigure): paced from this instant, no backlog.
  void set_factor(double factor, double sim, double wall, std::int64_t ros_ns);
  double factor() const { return factor_; }
  // Steps are paced (by the wall clock or by /clock), not run as fast as possible.
  bool paced() const { return source_ == TimeSource::kExternalClock || factor_ > 0.0; }

  // What observe() saw of an external clock.
  enum class Event { kNone, kStarted, kJumpedBack, kJumpedForward };
  // Once per loop iteration, before the steps: an external clock's first valid time, or a jump
  // (then re-anchored at the current state). kNone in the other sources.
  Event observe(double sim, double wall, std::int64_t ros_ns);
  // The last jump (s, negative back) and how many were seen, for the log and diagnostics.
  double last_jump() const { return last_jump_; }
  int jumps() const { return jumps_; }

  // Whole steps of length h due now (0 when unpaced or not ready).
  long steps_due(double sim, double wall, std::int64_t ros_ns, double h) const;
  // The state at simulation time `sim` is stamped at ROS time ros_ns from now on (a dropped
  // backlog, a resume, a reset, unpaced batches): pacing starts over from here, no backlog. With
  // an external clock the state's stamp never moves back (a paused clock after a state change).
  void anchor(double sim, double wall, std::int64_t ros_ns);
  // The backlog's start (wall s) as Pacer::behind_since; anchor() drops it.
  double behind_since() const { return pacer_.behind_since(); }
  void set_behind(bool behind, double wall) { pacer_.set_behind(behind, wall); }
  // Unpaced: the measured real-time factor, for sim_time_at (at least 1).
  void set_measured_rate(double rate) { measured_rate_ = rate > 1.0 ? rate : 1.0; }

  // The ROS time (ns) stamping the state at simulation time `sim`.
  std::int64_t stamp_ns(double sim) const;
  // The simulation time a ROS time (s, e.g. an input's header stamp) stands for: the inverse of
  // stamp_ns (to within 1e-7 s near today's epoch, double's resolution of the input).
  double sim_time_at(double ros_seconds) const;
  double sim_time_at_ns(std::int64_t ros_ns) const;  // the same, exact to the nanosecond
  // A ROS time interval (s) in simulation time.
  double sim_interval(double ros_seconds) const { return ros_seconds * rate(); }
  // Simulation seconds per ROS second.
  double rate() const;
  // How far (s) the state at `sim` is stamped behind ROS time ros_ns (negative: ahead).
  double lag(double sim, std::int64_t ros_ns) const {
    return 1e-9 * static_cast<double>(ros_ns - stamp_ns(sim));
  }

 private:
  static std::int64_t to_ns(double s) { return std::llround(s * 1e9); }

  TimeSource source_ = TimeSource::kWall;
  double factor_ = 1.0;
  bool ready_ = true;
  Pacer pacer_;  // wall pacing (kWall, kPublishClock) and the backlog's start (all)
  double sim_anchor_ = 0.0;
  std::int64_t ros_anchor_ns_ = 0;
  std::int64_t last_ros_ns_ = 0;  // the last ROS time observe() saw
  double last_wall_ = 0.0;        // and the wall time then
  double measured_rate_ = 1.0;
  double last_jump_ = 0.0;
  int jumps_ = 0;
};

// Header-only, as the adapter's other pure helpers (the unit tests build without ROS).

inline void NodeClock::start(TimeSource source, double factor, double sim, double wall,
                             std::int64_t ros_ns) {
  source_ = source;
  factor_ = factor;
  ready_ = source != TimeSource::kExternalClock || ros_ns > 0;
  last_ros_ns_ = ros_ns;
  last_wall_ = wall;
  pacer_.reset(source == TimeSource::kExternalClock ? 1.0 : factor, sim, wall);
  sim_anchor_ = sim;
  ros_anchor_ns_ = source == TimeSource::kPublishClock ? 0 : ros_ns;
}

inline void NodeClock::set_factor(double factor, double sim, double wall, std::int64_t ros_ns) {
  factor_ = factor;
  if (source_ == TimeSource::kExternalClock) return;  // /clock sets the pace
  pacer_.reset(factor, sim, wall);
  if (source_ == TimeSource::kWall) anchor(sim, wall, ros_ns);
}

inline NodeClock::Event NodeClock::observe(double sim, double wall, std::int64_t ros_ns) {
  if (source_ != TimeSource::kExternalClock) return Event::kNone;
  if (!ready_) {
    if (ros_ns <= 0) return Event::kNone;
    ready_ = true;
    last_ros_ns_ = ros_ns;
    last_wall_ = wall;
    sim_anchor_ = sim;
    ros_anchor_ns_ = ros_ns;
    pacer_.anchor(sim, wall);
    return Event::kStarted;
  }
  const double moved = 1e-9 * static_cast<double>(ros_ns - last_ros_ns_);
  const double elapsed = wall - last_wall_;
  if (moved < -kBackTolerance) {
    // Back (a bag played in a loop, a restarted clock): the state is stamped at the new time.
    last_ros_ns_ = ros_ns;
    last_wall_ = wall;
    sim_anchor_ = sim;
    ros_anchor_ns_ = ros_ns;
    pacer_.anchor(sim, wall);
    last_jump_ = moved;
    ++jumps_;
    return Event::kJumpedBack;
  }
  if (moved < 0.0) return Event::kNone;  // a small reordering: wait for the clock to pass it
  last_ros_ns_ = ros_ns;
  last_wall_ = wall;
  if (moved - elapsed > kJumpSeconds) {
    anchor(sim, wall, ros_ns);
    last_jump_ = moved;
    ++jumps_;
    return Event::kJumpedForward;
  }
  return Event::kNone;
}

inline long NodeClock::steps_due(double sim, double wall, std::int64_t ros_ns, double h) const {
  if (!ready_ || !paced()) return 0;
  if (source_ != TimeSource::kExternalClock) return pacer_.steps_due(sim, wall, h);
  if (!(h > 0.0)) return 0;
  // Up to the clock, never past it: the same whole-step rounding as the wall pacing.
  const double n = std::floor((sim_time_at_ns(ros_ns) - sim) / h + 1e-6);
  if (!(n > 0.0)) return 0;
  return n < static_cast<double>(Pacer::kMaxDue) ? static_cast<long>(n) : Pacer::kMaxDue;
}

inline void NodeClock::anchor(double sim, double wall, std::int64_t ros_ns) {
  pacer_.anchor(sim, wall);
  if (source_ == TimeSource::kPublishClock) return;  // stamps are simulation time
  if (source_ == TimeSource::kExternalClock) {
    if (!ready_) return;
    const std::int64_t now_stamp = stamp_ns(sim);
    if (ros_ns < now_stamp) ros_ns = now_stamp;  // never back (a clock standing still)
  }
  sim_anchor_ = sim;
  ros_anchor_ns_ = ros_ns;
}

inline double NodeClock::rate() const {
  if (source_ != TimeSource::kWall) return 1.0;
  return factor_ > 0.0 ? factor_ : measured_rate_;
}

inline std::int64_t NodeClock::stamp_ns(double sim) const {
  if (source_ == TimeSource::kPublishClock) return to_ns(sim);
  return ros_anchor_ns_ + to_ns((sim - sim_anchor_) / rate());
}

inline double NodeClock::sim_time_at_ns(std::int64_t ros_ns) const {
  if (source_ == TimeSource::kPublishClock) return 1e-9 * static_cast<double>(ros_ns);
  return sim_anchor_ + 1e-9 * static_cast<double>(ros_ns - ros_anchor_ns_) * rate();
}

inline double NodeClock::sim_time_at(double ros_seconds) const {
  if (source_ == TimeSource::kPublishClock) return ros_seconds;
  const double whole = std::floor(ros_seconds);
  const std::int64_t ns = static_cast<std::int64_t>(whole) * 1000000000LL;
  return sim_time_at_ns(ns) + (ros_seconds - whole) * rate();
}

}  // namespace corde_sim
