// Pure helpers of the ROS adapter (pacing, holder motion, input checks); no ROS needed.
#include <gtest/gtest.h>

#include "corde_sim/grasp/holder.h"
#include "corde_sim/ros/input_checks.h"
#include "corde_sim/ros/output_schedule.h"
#include "corde_sim/ros/pacer.h"

namespace corde_sim {
namespace {

TEST(Pacer, StepsFollowScaledWallTime) {
  Pacer p;
  p.reset(0.5, 10.0, 100.0);  // half real time, sim 10 s at wall 100 s
  const double h = 1e-3;
  EXPECT_EQ(p.steps_due(10.0, 100.0, h), 0);
  EXPECT_EQ(p.steps_due(10.0, 100.1, h), 50);  // 0.1 s wall = 0.05 s sim
  EXPECT_EQ(p.steps_due(10.05, 100.1, h), 0);  // already there
  EXPECT_EQ(p.steps_due(10.0, 100.0999, h), 49);
  EXPECT_NEAR(p.wall_at(10.05), 100.1, 1e-12);
  p.anchor(10.05, 200.0);  // a pause: no backlog afterwards
  EXPECT_EQ(p.steps_due(10.05, 200.0, h), 0);
}

TEST(Pacer, HugeBacklogIsClampedNotOverflowed) {
  // 3.6 s at h = 1e-300 is 3.6e300 steps: no long holds that (converting it is undefined
  // behaviour, -2^63 on x86, which read as no step due and stopped the clock).
  Pacer p;
  p.reset(1.0, 0.0, 0.0);
  EXPECT_EQ(p.steps_due(0.0, 3.6, 1e-300), Pacer::kMaxDue);
  EXPECT_EQ(p.steps_due(0.0, 1e300, 1e-3), Pacer::kMaxDue);
  EXPECT_EQ(p.steps_due(1e300, 0.0, 1e-3), 0);
}

TEST(Pacer, BacklogCountsFromWhenItBeganUntilAnchored) {
  Pacer p;
  p.reset(1.0, 0.0, 0.0);
  EXPECT_LT(p.behind_since(), 0.0);
  p.set_behind(true, 1.0);
  p.set_behind(true, 2.0);  // still the same backlog
  EXPECT_EQ(p.behind_since(), 1.0);
  p.set_behind(false, 3.0);
  EXPECT_LT(p.behind_since(), 0.0);
  p.set_behind(true, 4.0);
  EXPECT_EQ(p.behind_since(), 4.0);
  p.anchor(4.0, 5.0);  // dropped
  EXPECT_LT(p.behind_since(), 0.0);
}

TEST(Pacer, UnpacedNeverSchedules) {
  Pacer p;
  p.reset(0.0, 0.0, 0.0);
  EXPECT_FALSE(p.paced());
  EXPECT_EQ(p.steps_due(0.0, 1e6, 1e-4), 0);
}

TEST(HolderMotion, ReferenceMovesContinuouslyToEachGoal) {
  corde::HolderMotion h;
  Eigen::Isometry3d a = Eigen::Isometry3d::Identity();
  h.reset(a);
  Eigen::Isometry3d b = Eigen::Isometry3d::Identity();
  b.translation() = Eigen::Vector3d(1.0, 0.0, 0.0);
  b.linear() = Eigen::AngleAxisd(1.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  h.set_goal(2.0, b, 0.1);
  EXPECT_LT((h.reference(2.0).translation() - a.translation()).norm(), 1e-12);
  EXPECT_NEAR(h.reference(2.05).translation().x(), 0.5, 1e-12);
  EXPECT_NEAR(Eigen::AngleAxisd(h.reference(2.05).linear()).angle(), 0.5, 1e-12);
  EXPECT_LT((h.reference(2.2).translation() - b.translation()).norm(), 1e-12);
  // A new goal half-way starts from where the holder is, not from the old goal.
  Eigen::Isometry3d c = Eigen::Isometry3d::Identity();
  h.set_goal(2.05, c, 0.1);
  EXPECT_NEAR(h.reference(2.05).translation().x(), 0.5, 1e-12);
  EXPECT_NEAR(h.reference(2.10).translation().x(), 0.25, 1e-12);
  // Zero duration: at once.
  h.set_goal(3.0, b, 0.0);
  EXPECT_NEAR(h.reference(3.0).translation().x(), 1.0, 1e-12);
}

TEST(OutputSchedule, KeepsEachRateWhateverTheLoopDoes) {
  // Outputs at 50 and 20 Hz polled at irregular instants over 10 s: each is taken at its rate,
  // and after a stall it resumes one period later without a burst.
  OutputSchedule s;
  s.set_rate(OutputSchedule::kTf, 50.0);
  s.set_rate(OutputSchedule::kMarkers, 20.0);
  s.set_rate(OutputSchedule::kState, 0.0);
  s.start(0.0);
  int tf = 0, markers = 0, state = 0;
  double t = 0.0;
  for (int k = 0; t < 10.0; ++k) {
    t += (k % 7) * 1e-3 + 1e-4;
    tf += s.take(OutputSchedule::kTf, t);
    markers += s.take(OutputSchedule::kMarkers, t);
    state += s.take(OutputSchedule::kState, t);
    EXPECT_LE(s.next_due(), t + 0.05 + 1e-12);
  }
  EXPECT_NEAR(tf, 500, 2);
  EXPECT_NEAR(markers, 200, 2);
  EXPECT_EQ(state, 0);
  EXPECT_TRUE(s.take(OutputSchedule::kTf, t + 3.0));  // after a 3 s stall: once, then on period
  EXPECT_FALSE(s.take(OutputSchedule::kTf, t + 3.0));
  EXPECT_TRUE(s.take(OutputSchedule::kTf, t + 3.021));
}

TEST(OutputSchedule, OutputsWhoseRatesDivideStayTogetherAfterStalls) {
  // tf at 50 Hz and the state at 25 Hz: every state tick is also a tf tick, whatever stalls the
  // loop suffers (before, a stall could shift one output's phase for good).
  OutputSchedule s;
  s.set_rate(OutputSchedule::kTf, 50.0);
  s.set_rate(OutputSchedule::kState, 25.0);
  s.start(100.0);
  int states = 0, together = 0;
  double t = 100.0;
  for (int k = 0; k < 3000; ++k) {
    t += (k % 97 == 0) ? 0.0537 : 1e-3 * (1 + k % 3);  // irregular loop, with stalls
    const bool tf = s.take(OutputSchedule::kTf, t);
    const bool state = s.take(OutputSchedule::kState, t);
    states += state;
    together += state && tf;
  }
  EXPECT_GT(states, 100);
  EXPECT_EQ(together, states);
}

TEST(InputChecks, Poses) {
  Eigen::Quaterniond q(1.0005, 0.0, 0.0, 0.0);
  EXPECT_EQ(check_pose(Eigen::Vector3d::Zero(), &q), "");
  EXPECT_NEAR(q.norm(), 1.0, 1e-15);
  Eigen::Quaterniond bad(1.01, 0.0, 0.0, 0.0);
  EXPECT_NE(check_pose(Eigen::Vector3d::Zero(), &bad), "");
  Eigen::Quaterniond zero(0.0, 0.0, 0.0, 0.0);
  EXPECT_NE(check_pose(Eigen::Vector3d::Zero(), &zero), "");
  Eigen::Quaterniond ok = Eigen::Quaterniond::Identity();
  EXPECT_NE(check_pose(Eigen::Vector3d(NAN, 0, 0), &ok), "");
  Eigen::Quaterniond inf(INFINITY, 0, 0, 0);
  EXPECT_NE(check_pose(Eigen::Vector3d::Zero(), &inf), "");
  EXPECT_NE(check_vector(Eigen::Vector3d(0, INFINITY, 0), "force"), "");
}

TEST(InputChecks, EchoedInputsAreClipped) {
  EXPECT_EQ(clip("short"), "short");
  const std::string long_name(1 << 20, 'g');
  const std::string c = clip(long_name);
  EXPECT_EQ(c, std::string(kMaxEcho, 'g') + "... (1048576 characters)");
  EXPECT_EQ(check_name_length(std::string(kMaxNameLength, 'a'), "grasp name"), "");
  EXPECT_NE(check_name_length(long_name, "grasp name").find("longer than 256"), std::string::npos);
  EXPECT_LT(check_name_length(long_name, "grasp name").size(), 200u);
  EXPECT_TRUE(valid_frame_chars("robot/tool0.link-1"));
  EXPECT_FALSE(valid_frame_chars("a b"));
}

TEST(InputChecks, StampAge) {
  EXPECT_EQ(check_stamp_age(0.5, false, 1.0), "");
  EXPECT_NE(check_stamp_age(1.5, false, 1.0), "");
  EXPECT_NE(check_stamp_age(-1.5, false, 1.0), "");
  EXPECT_EQ(check_stamp_age(1e9, true, 1.0), "");  // zero stamp: "now"
}

}  // namespace
}  // namespace corde_sim
