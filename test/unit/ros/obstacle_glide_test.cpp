// ObstacleGlide: how the node moves a robot link's obstacle between two tf poses. Analytic
// references: constant velocity d / T and angular velocity angle / T, the target reached exactly
// after T, the caps stretching T, the step velocities integrating to the motion, and a steady
// motion kept steady when its poses are picked up early or late.
#include "corde_sim/ros/obstacle_glide.h"

#include <gtest/gtest.h>

#include <cmath>

namespace corde_sim {
namespace {

Eigen::Isometry3d pose(const Eigen::Vector3d& p, double angle_z) {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.translation() = p;
  t.linear() = Eigen::AngleAxisd(angle_z, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return t;
}

TEST(ObstacleGlide, ConstantVelocityReachesTheTargetExactly) {
  ObstacleGlide g;
  g.reset(pose({0, 0, 1}, 0.0));
  EXPECT_FALSE(g.moving());
  const double h = 3e-4, interval = 0.01;  // 10 ms between tf messages: 33.3 steps
  const Eigen::Isometry3d target = pose({0.01, 0.0, 1.0}, 0.05);
  EXPECT_TRUE(g.glide_to(target, interval, 5.0, 30.0, 0.1));
  EXPECT_LT((g.step_linear_velocity(h) - Eigen::Vector3d(1.0, 0, 0)).norm(), 1e-12);  // 1 m/s
  EXPECT_LT((g.step_angular_velocity(h) - Eigen::Vector3d(0, 0, 5.0)).norm(), 1e-9);  // 5 rad/s
  // Integrating the step velocities gives the poses the glide reports (and ends at the target).
  Eigen::Vector3d x = g.pose().translation();
  double angle = 0.0;
  int steps = 0;
  while (g.moving()) {
    x += h * g.step_linear_velocity(h);
    angle += h * g.step_angular_velocity(h).z();
    g.advance(h);
    ++steps;
    EXPECT_LT((g.pose().translation() - x).norm(), 1e-12);
  }
  EXPECT_EQ(steps, 34);  // ceil(0.01 / 3e-4)
  EXPECT_LT((g.pose().matrix() - target.matrix()).norm(), 1e-12);
  EXPECT_NEAR(angle, 0.05, 1e-12);
  EXPECT_EQ(g.step_linear_velocity(h).norm(), 0.0);  // at rest afterwards
}

TEST(ObstacleGlide, CapsStretchAJump) {
  ObstacleGlide g;
  g.reset(pose({0, 0, 0}, 0.0));
  // 1 m in 10 ms would be 100 m/s: capped at 5 m/s, the glide takes 0.2 s.
  EXPECT_FALSE(g.glide_to(pose({1, 0, 0}, 0.0), 0.01, 5.0, 30.0, 0.1));
  EXPECT_NEAR(g.step_linear_velocity(1e-3).norm(), 5.0, 1e-12);
  // A half turn in 10 ms: capped at 30 rad/s.
  g.reset(pose({0, 0, 0}, 0.0));
  EXPECT_FALSE(g.glide_to(pose({0, 0, 0}, 3.0), 0.01, 5.0, 30.0, 0.1));
  EXPECT_NEAR(g.step_angular_velocity(1e-3).norm(), 30.0, 1e-9);
  for (int i = 0; i < 100; ++i) g.advance(1e-3);  // 0.1 s of the 0.1 s
  EXPECT_LT((g.pose().matrix() - pose({0, 0, 0}, 3.0).matrix()).norm(), 1e-9);
}

TEST(ObstacleGlide, PoseArrivingBeforeTheGlideEndsKeepsTheLinkSpeed) {
  // A link moving steadily at 1 m/s, its tf poses 10 ms apart, the second one picked up 5 ms
  // early (tf arrives and the node looks it up with jitter): the glide goes on to the new pose
  // at 1 m/s, reaching it one interval after the first one, instead of doubling its speed.
  ObstacleGlide g;
  g.reset(pose({0, 0, 0}, 0.0));
  g.glide_to(pose({0.01, 0, 0}, 0.0), 0.01, 5.0, 30.0, 0.1);
  for (int i = 0; i < 5; ++i) g.advance(1e-3);  // half way: x = 5 mm
  EXPECT_NEAR(g.pose().translation().x(), 0.005, 1e-12);
  EXPECT_TRUE(g.glide_to(pose({0.02, 0, 0}, 0.0), 0.01, 5.0, 30.0, 0.1));
  EXPECT_NEAR(g.step_linear_velocity(1e-3).x(), 1.0, 1e-12);
  int steps = 0;
  while (g.moving()) {
    g.advance(1e-3);
    ++steps;
  }
  EXPECT_EQ(steps, 15);
  EXPECT_NEAR(g.pose().translation().x(), 0.02, 1e-12);
  // A pose picked up late (the glide ended 3 ms ago): from rest over its interval, not faster.
  for (int i = 0; i < 3; ++i) g.advance(1e-3);
  g.glide_to(pose({0.03, 0, 0}, 0.0), 0.01, 5.0, 30.0, 0.1);
  EXPECT_NEAR(g.step_linear_velocity(1e-3).x(), 1.0, 1e-12);
  // Same pose again (no interval): nothing moves.
  g.reset(pose({0, 0, 0}, 0.0));
  EXPECT_TRUE(g.glide_to(pose({0, 0, 0}, 0.0), 0.0, 5.0, 30.0, 0.1));
  EXPECT_FALSE(g.moving());
}

TEST(ObstacleGlide, LagBehindThePosesIsBounded) {
  // Poses keep coming before the glide ends (a simulation slower than the robot): the glide
  // reaches the newest pose at most max_lag plus one interval after it came, speeding up to keep
  // that bound instead of falling further behind.
  ObstacleGlide g;
  g.reset(pose({0, 0, 0}, 0.0));
  const double h = 1e-3, interval = 0.01, max_lag = 0.03;
  for (int k = 1; k <= 20; ++k) {
    g.glide_to(pose({0.01 * k, 0, 0}, 0.0), interval, 5.0, 30.0, max_lag);
    EXPECT_GE(g.step_linear_velocity(h).x(), 1.0 - 1e-12);
    for (int i = 0; i < 5; ++i) g.advance(h);  // only 5 ms simulated per 10 ms of poses
  }
  EXPECT_GT(g.step_linear_velocity(h).x(), 1.5);
  int steps = 0;
  while (g.moving()) {
    g.advance(h);
    ++steps;
  }
  EXPECT_LE(steps, static_cast<int>(std::ceil((max_lag + interval) / h)) - 5);
  EXPECT_NEAR(g.pose().translation().x(), 0.2, 1e-12);
}

}  // namespace
}  // namespace corde_sim
