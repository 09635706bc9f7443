// The node's time model (node_clock.h) in its three time sources; no ROS needed.
#include "corde_sim/ros/node_clock.h"

#include <gtest/gtest.h>

#include <cstdint>

namespace corde_sim {
namespace {

constexpr double kH = 1e-3;  // s, the step
constexpr std::int64_t kSec = 1000000000LL;

// Runs the steps due like the node's loop (all of them) and returns the new simulation time.
double run_due(const NodeClock& c, double sim, double wall, std::int64_t ros) {
  return sim + static_cast<double>(c.steps_due(sim, wall, ros, kH)) * kH;
}

TEST(NodeClock, PublishClockStampsAreSimulationTime) {
  NodeClock c;
  c.start(TimeSource::kPublishClock, 1.0, 0.0, 50.0, 0);
  EXPECT_TRUE(c.ready());
  EXPECT_EQ(c.steps_due(0.0, 50.1, 0, kH), 100);  // paced on the wall clock
  EXPECT_EQ(c.stamp_ns(2.5), 2500000000LL);
  EXPECT_DOUBLE_EQ(c.sim_time_at(2.5), 2.5);
  c.anchor(2.5, 60.0, 123 * kSec);  // a reset: the stamps stay the simulation time
  EXPECT_EQ(c.stamp_ns(2.5), 2500000000LL);
  EXPECT_EQ(c.observe(2.5, 60.0, 0), NodeClock::Event::kNone);
}

TEST(NodeClock, ExternalClockWaitsForAValidTime) {
  NodeClock c;
  c.start(TimeSource::kExternalClock, 1.0, 0.0, 10.0, 0);
  EXPECT_FALSE(c.ready());
  EXPECT_EQ(c.steps_due(0.0, 20.0, 0, kH), 0);  // wall time passing does not step it
  EXPECT_EQ(c.observe(0.0, 20.0, 0), NodeClock::Event::kNone);
  EXPECT_EQ(c.observe(0.0, 20.0, 1000 * kSec), NodeClock::Event::kStarted);
  EXPECT_TRUE(c.ready());
  EXPECT_EQ(c.stamp_ns(0.0), 1000 * kSec);
}

TEST(NodeClock, ExternalClockPacesAndIsNeverAhead) {
  NodeClock c;
  c.start(TimeSource::kExternalClock, 5.0, 0.0, 0.0, 1000 * kSec);  // factor unused
  EXPECT_TRUE(c.ready());
  double sim = 0.0;
  std::int64_t ros = 1000 * kSec;
  for (int i = 0; i < 100; ++i) {
    ros += 7300000;  // 7.3 ms of clock per loop iteration
    EXPECT_EQ(c.observe(sim, 0.0, ros), NodeClock::Event::kNone);
    sim = run_due(c, sim, 1e9, ros);  // wall time plays no part
    EXPECT_LE(c.stamp_ns(sim), ros);
    EXPECT_LT(c.lag(sim, ros), kH + 1e-9);
  }
  EXPECT_NEAR(sim, 0.73, kH);
  // The clock stands still: no step is due, however much wall time passes.
  EXPECT_EQ(c.steps_due(sim, 1e12, ros, kH), 0);
  EXPECT_EQ(c.observe(sim, 2e9, ros), NodeClock::Event::kNone);
  EXPECT_EQ(c.steps_due(sim, 2e9, ros, kH), 0);
  // Input stamps map to simulation time one to one, inverse of the stamps.
  EXPECT_NEAR(c.sim_time_at(1000.5), 0.5, 1e-6);
  EXPECT_NEAR(c.sim_time_at(1e-9 * static_cast<double>(c.stamp_ns(0.4))), 0.4, 1e-6);
  EXPECT_DOUBLE_EQ(c.sim_interval(0.01), 0.01);
}

TEST(NodeClock, ExternalClockJumpsReanchor) {
  NodeClock c;
  c.start(TimeSource::kExternalClock, 1.0, 0.0, 0.0, 1000 * kSec);
  EXPECT_EQ(c.observe(0.0, 0.0, 1000 * kSec + kSec / 2), NodeClock::Event::kNone);
  double sim = run_due(c, 0.0, 0.0, 1000 * kSec + kSec / 2);
  EXPECT_NEAR(sim, 0.5, kH);
  // Back by 400 s (a bag looping): the state is stamped at the new clock time, no steps due.
  const std::int64_t back = 600 * kSec;
  EXPECT_EQ(c.observe(sim, 0.0, back), NodeClock::Event::kJumpedBack);
  EXPECT_EQ(c.jumps(), 1);
  EXPECT_NEAR(c.last_jump(), -400.5, 1e-6);
  EXPECT_EQ(c.stamp_ns(sim), back);
  EXPECT_EQ(c.steps_due(sim, 0.0, back, kH), 0);
  EXPECT_EQ(c.observe(sim, 0.0, back + kSec / 10), NodeClock::Event::kNone);
  sim = run_due(c, sim, 0.0, back + kSec / 10);
  EXPECT_NEAR(sim, 0.6, kH);
  // Forward by a day: re-anchored, not 86.4 million steps due.
  const std::int64_t fwd = back + 86400 * kSec;
  EXPECT_EQ(c.observe(sim, 0.0, fwd), NodeClock::Event::kJumpedForward);
  EXPECT_EQ(c.jumps(), 2);
  EXPECT_EQ(c.steps_due(sim, 0.0, fwd, kH), 0);
  EXPECT_EQ(c.stamp_ns(sim), fwd);
  // A loop stalled for 3 s of wall time while the clock ran on: no jump, the steps are due.
  EXPECT_EQ(c.observe(sim, 3.0, fwd + 3 * kSec), NodeClock::Event::kNone);
  EXPECT_EQ(c.steps_due(sim, 3.0, fwd + 3 * kSec, kH), 3000);
  EXPECT_EQ(c.jumps(), 2);
  // A small reordering (a late clock message) is no jump and steps nothing.
  EXPECT_EQ(c.observe(sim, 3.0, fwd + 3 * kSec - kSec / 10000), NodeClock::Event::kNone);
  EXPECT_EQ(c.jumps(), 2);
}

TEST(NodeClock, ExternalClockStandingStillNeverStampsBack) {
  NodeClock c;
  c.start(TimeSource::kExternalClock, 1.0, 0.0, 0.0, 1000 * kSec);
  double sim = run_due(c, 0.0, 0.0, 1001 * kSec);
  const std::int64_t before = c.stamp_ns(sim);
  sim += kH;  // a state changed by a service: one step later
  c.anchor(sim, 0.0, 1001 * kSec);
  EXPECT_GT(c.stamp_ns(sim), before);  // later, one step ahead of the still clock
  EXPECT_EQ(c.steps_due(sim, 0.0, 1001 * kSec, kH), 0);
  EXPECT_EQ(c.steps_due(sim, 0.0, 1001 * kSec + kSec / 100, kH), 9);
}

TEST(NodeClock, WallStampsAreWhenAStateWasDue) {
  NodeClock c;
  const std::int64_t ros0 = 1700000000LL * kSec;  // today's epoch: 1 ns kept
  c.start(TimeSource::kWall, 2.0, 0.0, 100.0, ros0);
  EXPECT_EQ(c.steps_due(0.0, 100.1, 0, kH), 200);  // paced on wall time at factor 2
  // The state at 0.2 s was due 0.1 s after the start, and is stamped so.
  EXPECT_EQ(c.stamp_ns(0.2), ros0 + kSec / 10);
  EXPECT_EQ(c.stamp_ns(0.2 + kH) - c.stamp_ns(0.2), 500000);
  EXPECT_NEAR(c.sim_time_at(1700000000.1), 0.2, 1e-6);
  EXPECT_DOUBLE_EQ(c.sim_interval(0.01), 0.02);
  // Behind by 0.5 s of work: the backlog is dropped and the current state stamped now.
  c.set_behind(true, 100.2);
  c.anchor(0.3, 100.7, ros0 + 7 * kSec / 10);
  EXPECT_LT(c.behind_since(), 0.0);
  EXPECT_EQ(c.stamp_ns(0.3), ros0 + 7 * kSec / 10);
  EXPECT_EQ(c.steps_due(0.3, 100.7, 0, kH), 0);
  EXPECT_NEAR(c.lag(0.3, ros0 + 7 * kSec / 10), 0.0, 1e-12);
}

TEST(NodeClock, WallFactorAboveOneNeverStampsAhead) {
  NodeClock c;
  const std::int64_t ros0 = 5 * kSec;
  c.start(TimeSource::kWall, 10.0, 0.0, 0.0, ros0);
  double sim = 0.0;
  for (int i = 1; i <= 50; ++i) {
    const double wall = 0.005 * i;
    const std::int64_t ros = ros0 + static_cast<std::int64_t>(wall * 1e9);
    sim = run_due(c, sim, wall, ros);
    EXPECT_LE(c.stamp_ns(sim), ros);
    EXPECT_GE(c.lag(sim, ros), 0.0);
    EXPECT_LT(c.lag(sim, ros), kH / 10.0 + 1e-9);
  }
  EXPECT_NEAR(sim, 2.5, kH);
}

TEST(NodeClock, WallUnpacedBatchesAreStampedWhenComputed) {
  NodeClock c;
  const std::int64_t ros0 = 50 * kSec;
  c.start(TimeSource::kWall, 0.0, 0.0, 0.0, ros0);
  EXPECT_FALSE(c.paced());
  EXPECT_EQ(c.steps_due(0.0, 1e6, ros0, kH), 0);
  // 27 s of simulation in 1 s: the state is stamped at its batch's end, not 26 s ahead.
  c.set_measured_rate(27.0);
  c.anchor(27.0, 1.0, ros0 + kSec);
  EXPECT_EQ(c.stamp_ns(27.0), ros0 + kSec);
  EXPECT_NEAR(c.sim_interval(0.1), 2.7, 1e-12);
  EXPECT_NEAR(c.sim_time_at(51.0), 27.0, 1e-9);
  // A reset one step later: stamped at the ROS time of the reset.
  c.anchor(27.0 + kH, 1.5, ros0 + 3 * kSec / 2);
  EXPECT_EQ(c.stamp_ns(27.0 + kH), ros0 + 3 * kSec / 2);
}

TEST(NodeClock, NewFactorRepacesFromNow) {
  NodeClock c;
  c.start(TimeSource::kWall, 1.0, 0.0, 0.0, 10 * kSec);
  c.set_factor(0.5, 1.0, 1.0, 11 * kSec);
  EXPECT_EQ(c.stamp_ns(1.0), 11 * kSec);
  EXPECT_EQ(c.stamp_ns(1.5), 12 * kSec);
  EXPECT_EQ(c.steps_due(1.0, 2.0, 12 * kSec, kH), 500);
  NodeClock e;  // an external clock keeps its pace whatever the factor
  e.start(TimeSource::kExternalClock, 1.0, 0.0, 0.0, 10 * kSec);
  e.set_factor(0.1, 0.0, 0.0, 10 * kSec);
  EXPECT_EQ(e.steps_due(0.0, 0.0, 11 * kSec, kH), 1000);
}

}  // namespace
}  // namespace corde_sim
