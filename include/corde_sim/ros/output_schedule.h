// When the node's periodic outputs are due (no ROS). Each output keeps its own rate on the steady
// wall clock whatever else happens: service calls, resets and grasps change what is published,
// never when, so a burst of requests cannot delay or silence an output.
#pragma once

#include <algorithm>
#include <array>
#include <limits>

namespace corde_sim {

class OutputSchedule {
 public:
  enum Output { kTf, kMarkers, kState, kCount };

  // rate 0 = never due.
  void set_rate(Output o, double hz) { period_[o] = hz > 0.0 ? 1.0 / hz : 0.0; }
  double rate(Output o) const { return period_[o] > 0.0 ? 1.0 / period_[o] : 0.0; }
  // Every output due at `now`.
  void start(double now) { next_.fill(now); }
  // True if `o` is due at `now`; its next deadline is then one period on (or one period from now
  // after a stall: no burst to catch up).
  bool take(Output o, double now) {
    if (period_[o] <= 0.0 || now < next_[o]) return false;
    next_[o] += period_[o];
    if (next_[o] < now) next_[o] = now + period_[o];
    return true;
  }
  // Earliest deadline of an output that is on (infinity if none).
  double next_due() const {
    double t = std::numeric_limits<double>::infinity();
    for (int o = 0; o < kCount; ++o)
      if (period_[o] > 0.0) t = std::min(t, next_[o]);
    return t;
  }

 private:
  std::array<double, kCount> period_{};
  std::array<double, kCount> next_{};
};

}  // namespace corde_sim
