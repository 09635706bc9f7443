// Wall-clock pacing of the simulation (no ROS): how many whole steps are due so that simulation
// time follows wall time scaled by the real-time factor. Never waits on ROS time, so it works
// when the node itself publishes /clock.
#pragma once

#include <cmath>

namespace corde_sim {

class Pacer {
 public:
  // factor 0 means unpaced (as fast as possible).
  void reset(double factor, double sim_time, double wall_time) {
    factor_ = factor;
    anchor(sim_time, wall_time);
  }
  // Simulation time sim_time corresponds to wall_time from now on (after a pause, or to drop a
  // backlog the simulation could not keep up with).
  void anchor(double sim_time, double wall_time) {
    sim_anchor_ = sim_time;
    wall_anchor_ = wall_time;
    behind_since_ = -1.0;
  }
  // The wall time since which steps have been due but not all run (a batch stopped at an output
  // and goes on after it), or a negative value: the caller's budget for a backlog counts from
  // there. anchor() drops the backlog.
  double behind_since() const { return behind_since_; }
  void set_behind(bool behind, double wall_time) {
    if (!behind)
      behind_since_ = -1.0;
    else if (behind_since_ < 0.0)
      behind_since_ = wall_time;
  }
  static constexpr long kMaxDue = 1L << 40;

  bool paced() const { return factor_ > 0.0; }
  double factor() const { return factor_; }
  // Whole steps of length h due at wall_time. The small tolerance keeps rounding from delaying a
  // step that is due exactly now.
  long steps_due(double sim_time, double wall_time, double h) const {
    if (!paced() || !(h > 0.0)) return 0;
    const double target = sim_anchor_ + factor_ * (wall_time - wall_anchor_);
    const double n = std::floor((target - sim_time) / h + 1e-6);
    // Clamped before converting: a tiny h or a long stall would not fit a long (undefined
    // behaviour); a batch stops at its deadline long before kMaxDue steps anyway.
    if (!(n > 0.0)) return 0;
    return n < static_cast<double>(kMaxDue) ? static_cast<long>(n) : kMaxDue;
  }
  // Wall time at which the simulation reaches sim_time.
  double wall_at(double sim_time) const {
    return paced() ? wall_anchor_ + (sim_time - sim_anchor_) / factor_ : wall_anchor_;
  }

 private:
  double factor_ = 1.0;
  double sim_anchor_ = 0.0, wall_anchor_ = 0.0;
  double behind_since_ = -1.0;
};

}  // namespace corde_sim
