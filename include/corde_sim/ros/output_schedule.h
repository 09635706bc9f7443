// When the node's periodic outputs are due (no ROS). Each output keeps its own rate on the steady
// wall clock whatever else happens: service calls, resets and grasps change what is published,
// never when, so a burst of requests cannot delay or silence an output.
//
// Deadlines lie on a grid fixed at start(): output o is due at start + k / rate_o. Outputs whose
// rates divide each other fall due together (tf at 50 Hz and the state at 25 Hz share every other
// stamp), also after a stall, which skips the missed ticks instead of bursting to catch up.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

namespace corde_sim {

class OutputSchedule {
 public:
  enum Output { kTf, kMarkers, kState, kCloud, kCount };

  // rate 0 = never due. A new rate takes effect from the next tick after the last time seen.
  void set_rate(Output o, double hz) {
    period_[o] = hz > 0.0 ? 1.0 / hz : 0.0;
    if (period_[o] > 0.0) tick_[o] = std::floor((last_ - start_) / period_[o]) + 1.0;
  }
  double rate(Output o) const { return period_[o] > 0.0 ? 1.0 / period_[o] : 0.0; }
  // Every output due at `now`.
  void start(double now) {
    start_ = last_ = now;
    tick_.fill(0.0);
  }
  // True if `o` is due at `now`; its next deadline is then the first grid point after `now`.
  bool take(Output o, double now) {
    last_ = std::max(last_, now);
    if (period_[o] <= 0.0 || now < deadline(o)) return false;
    tick_[o] = std::max(tick_[o] + 1.0, std::floor((now - start_) / period_[o]) + 1.0);
    return true;
  }
  // Earliest deadline of an output that is on (infinity if none).
  double next_due() const {
    double t = std::numeric_limits<double>::infinity();
    for (int o = 0; o < kCount; ++o)
      if (period_[o] > 0.0) t = std::min(t, deadline(static_cast<Output>(o)));
    return t;
  }

 private:
  double deadline(Output o) const { return start_ + tick_[o] * period_[o]; }

  double start_ = 0.0, last_ = 0.0;
  std::array<double, kCount> period_{};
  std::array<double, kCount> tick_{};
};

}  // namespace corde_sim
