// Pose streams followed by their stamps (PoseTimeline, HolderMotion::add_sample): a circle sent at
// 10 Hz to 1 kHz with jittery arrival is traced within 1 mm at its pace; stamps out of order or
// repeated change nothing; a stream that stops holds its last pose and resumes from there.
#include "corde_sim/grasp/pose_timeline.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "corde_sim/grasp/holder.h"

namespace corde {
namespace {

constexpr double kRadius = 0.05;  // m
constexpr double kSpeed = 0.157;  // m/s
constexpr double kOmega = kSpeed / kRadius;

Eigen::Isometry3d on_circle(double t) {
  Eigen::Isometry3d p = Eigen::Isometry3d::Identity();
  p.translation() << 0.0, kRadius * std::cos(kOmega * t), 1.0 + kRadius * std::sin(kOmega * t);
  p.linear() = Eigen::AngleAxisd(0.3 * kOmega * t, Eigen::Vector3d::UnitX()).toRotationMatrix();
  return p;
}

double off_circle(const Eigen::Vector3d& p) {
  return std::hypot(p.x(), std::hypot(p.y(), p.z() - 1.0) - kRadius);
}

// A deterministic jitter in [0, 1).
double jitter(int k) { return std::fmod(0.6180339887 * (k + 1) * (k % 7 + 1), 1.0); }

struct Trace {
  double worst_off = 0.0;      // m from the circle
  double worst_angle = 0.0;    // rad from the commanded rotation at the reference time
  std::vector<double> speeds;  // m/s over each step
};

// A circle streamed at `rate`, each pose arriving 0-5 ms after its stamp (the first of every
// quarter second 30 ms: a loaded machine's hiccups),
// taken in by a simulation stepping at h; the reference is measured from t = 0.5 s to 3 s.
Trace stream_circle(double rate, double h = 2.5e-4) {
  HolderMotion m;
  m.reset(on_circle(0.0));
  Trace out;
  int k = 0;  // next pose to send
  Eigen::Vector3d prev = m.reference(0.0).translation();
  for (double t = 0.0; t < 3.0; t += h) {
    // Every pose that has arrived by t is added before the step from t.
    while (true) {
      const double stamp = k / rate;
      const bool hiccup = k > 0 && std::floor(4.0 * stamp) > std::floor(4.0 * (k - 1) / rate);
      const double arrival = stamp + (hiccup ? 0.03 : 0.005 * jitter(k));
      if (arrival > t) break;
      EXPECT_TRUE(m.add_sample(t, stamp, on_circle(stamp)));
      ++k;
    }
    const Eigen::Isometry3d ref = m.reference(t + h);
    if (t >= 0.5) {
      out.worst_off = std::max(out.worst_off, off_circle(ref.translation()));
      const double tau = m.stream().reference_time(t + h);
      const Eigen::AngleAxisd d(on_circle(tau).linear().transpose() * ref.linear());
      out.worst_angle = std::max(out.worst_angle, std::abs(d.angle()));
      out.speeds.push_back((ref.translation() - prev).norm() / h);
    }
    prev = ref.translation();
  }
  return out;
}

TEST(PoseTimeline, CircleIsTracedAtEveryRate) {
  for (double rate : {10.0, 50.0, 200.0, 1000.0}) {
    const Trace tr = stream_circle(rate);
    std::vector<double> v = tr.speeds;
    std::sort(v.begin(), v.end());
    const double p10 = v[v.size() / 10], p90 = v[v.size() * 9 / 10];
    EXPECT_LT(tr.worst_off, 1e-3) << rate << " Hz";
    // Linear between poses: the chord's sagitta is the error, R (1 - cos(w / 2 rate)).
    EXPECT_LT(tr.worst_off, kRadius * (1.0 - std::cos(kOmega / (2.0 * rate))) + 1e-9) << rate;
    // The rotation slerped between the poses: the commanded one, which turns about one axis.
    EXPECT_LT(tr.worst_angle, 1e-9) << rate << " Hz: the rotation is not the stream's";
    // At the commanded pace, never at rest: within the rate's warp while the delay settles.
    EXPECT_GT(p10, (1.0 - PoseTimeline::kWarp) * kSpeed * 0.99) << rate << " Hz";
    EXPECT_LT(p90, (1.0 + PoseTimeline::kWarp) * kSpeed * 1.01) << rate << " Hz";
    EXPECT_GT(v.front(), 0.5 * kSpeed) << rate << " Hz: the reference stopped";
  }
}

TEST(PoseTimeline, DelayIsOneGapAndBounded) {
  PoseTimeline tl;
  const Eigen::Vector3d p = Eigen::Vector3d::Zero();
  const Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
  // 100 Hz, each pose arriving 4 ms after its stamp: the delay starts at kFirstDelay and settles
  // at the gap from a stamp to the next arrival, 10 + 4 ms, plus the margin.
  EXPECT_TRUE(tl.add(0.004, 0.0, p, q, p, q));
  EXPECT_DOUBLE_EQ(tl.delay(0.004), PoseTimeline::kFirstDelay);
  int k = 1;
  for (; k < 2000; ++k) tl.add(0.01 * k + 0.004, 0.01 * k, p, q, p, q);
  const double now = 0.01 * k;
  EXPECT_NEAR(tl.delay(now), 0.014 + PoseTimeline::kDelayMargin, 1e-9);
  // One pose late by nearly kMaxDelay: the delay grows to its bound, no further.
  const double late = PoseTimeline::kMaxDelay - 0.011;  // a gap of kMaxDelay - 1 ms
  tl.add(now + late, now, p, q, p, q);
  EXPECT_NEAR(tl.delay(now + late), late + 0.01, 1e-9);  // held, from the last stamp
  EXPECT_NEAR(tl.delay(100.0), PoseTimeline::kMaxDelay, 1e-12);
}

TEST(PoseTimeline, OutOfOrderAndRepeatedStampsChangeNothing) {
  HolderMotion m;
  m.reset(on_circle(0.0));
  double t = 0.0;
  for (int k = 0; k < 20; ++k, t += 0.02) ASSERT_TRUE(m.add_sample(t, t, on_circle(t)));
  const PoseTimeline before = m.stream();
  const Eigen::Isometry3d ref = m.reference(t);
  EXPECT_FALSE(m.add_sample(t, t - 0.02, on_circle(0.0)));      // repeated stamp
  EXPECT_FALSE(m.add_sample(t, t - 0.1, on_circle(0.0)));       // older
  EXPECT_FALSE(m.add_sample(t, std::nan(""), on_circle(0.0)));  // not a time
  EXPECT_FALSE(m.add_sample(t, -INFINITY, on_circle(0.0)));
  ASSERT_EQ(m.stream().size(), before.size());
  for (int i = 0; i < before.size(); ++i) EXPECT_EQ(m.stream().get(i).time, before.get(i).time);
  EXPECT_TRUE(m.reference(t).isApprox(ref, 0.0));
  // The stored times only increase.
  for (int i = 1; i < m.stream().size(); ++i)
    EXPECT_GT(m.stream().get(i).time, m.stream().get(i - 1).time);
}

TEST(PoseTimeline, StoppedStreamHoldsAndResumesWithoutJump) {
  HolderMotion m;
  m.reset(on_circle(0.0));
  const HolderLimits lim;
  const double h = 2.5e-4;
  double t = 0.0, worst_step = 0.0;
  int k = 0;
  Eigen::Vector3d prev = m.reference(0.0).translation();
  for (; t < 4.0; t += h) {
    // Poses at 50 Hz for 1 s, none for 2 s, then again from where the circle would be.
    const double stamp = 0.02 * k;
    if (stamp <= t && (stamp < 1.0 || stamp >= 3.0)) {
      m.add_sample(t, stamp, on_circle(stamp));
      ++k;
    } else if (stamp <= t) {
      ++k;
    }
    m.advance(t, h, lim);
    const Eigen::Vector3d p = m.reference(t + h).translation();
    worst_step = std::max(worst_step, (p - prev).norm());
    prev = p;
    if (t > 2.0 && t < 3.0) {
      // Holds the last pose sent, and the holder comes to rest there.
      EXPECT_LT((p - on_circle(0.98).translation()).norm(), 1e-12);
    }
  }
  EXPECT_FALSE(m.moving() && (m.pose().translation() - prev).norm() > 1e-3);
  // No jump anywhere (the resume starts from the held pose): steps of the speed, a little more
  // while the delay shrinks and the chord from the held pose to the resumed circle.
  EXPECT_LT(worst_step, 2.0 * kSpeed * h + 1e-9);
}

TEST(PoseTimeline, UnstampedGoalEndsTheStream) {
  HolderMotion m;
  m.reset(on_circle(0.0));
  for (int k = 0; k < 10; ++k) m.add_sample(0.01 * k, 0.01 * k, on_circle(0.01 * k));
  EXPECT_TRUE(m.streaming());
  const Eigen::Isometry3d here = m.reference(0.1);
  Eigen::Isometry3d goal = here;
  goal.translation().x() += 0.01;
  m.set_goal(0.1, goal, 0.05);
  EXPECT_FALSE(m.streaming());
  EXPECT_TRUE(m.reference(0.1).isApprox(here, 1e-12));  // from where the stream was
  EXPECT_TRUE(m.reference(0.15).isApprox(goal, 1e-12));
}

TEST(PoseTimeline, FullTimelineThinsOutAheadOfTheReference) {
  PoseTimeline tl;
  const Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
  // Poses stamped far ahead of the simulation (a clock running slow) on the line y = x: every
  // one is kept until it is full, then every other one ahead, never the first ones or the newest.
  const int n = 3 * PoseTimeline::kCapacity;
  for (int k = 0; k < n; ++k)
    tl.add(0.0, 0.001 * (k + 1), Eigen::Vector3d(k, k, 0), q, Eigen::Vector3d::Zero(), q);
  EXPECT_LE(tl.size(), PoseTimeline::kCapacity);
  EXPECT_GT(tl.size(), PoseTimeline::kCapacity / 2);
  EXPECT_EQ(tl.newest().p.x(), n - 1);
  EXPECT_EQ(tl.get(1).p.x(), 0.0);  // (get(0) holds the start)
  for (int i = 1; i < tl.size(); ++i) EXPECT_GT(tl.get(i).time, tl.get(i - 1).time);
  // Still on the commanded path everywhere between the first pose and the newest.
  Eigen::Vector3d p;
  Eigen::Quaterniond r;
  for (double t = 0.0; t < 1.0; t += 1e-3) {
    tl.at(t, &p, &r);
    if (tl.reference_time(t) < 0.001 || tl.reference_time(t) > tl.newest().time) continue;
    EXPECT_NEAR(p.x(), p.y(), 1e-12);
    EXPECT_NEAR(p.x(), 1000.0 * tl.reference_time(t) - 1.0, 1e-9);
  }
}

}  // namespace
}  // namespace corde
