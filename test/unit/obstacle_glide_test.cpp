// ObstacleGlide: how the node moves a robot link's obstacle between two tf poses. Analytic
// references: constant velocity d / T and angular velocity angle / T, the target reached exactly
// after T, the caps stretching T, and the step velocities integrating to the motion.
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
  EXPECT_TRUE(g.glide_to(target, interval, 5.0, 30.0));
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
  EXPECT_FALSE(g.glide_to(pose({1, 0, 0}, 0.0), 0.01, 5.0, 30.0));
  EXPECT_NEAR(g.step_linear_velocity(1e-3).norm(), 5.0, 1e-12);
  // A half turn in 10 ms: capped at 30 rad/s.
  g.reset(pose({0, 0, 0}, 0.0));
  EXPECT_FALSE(g.glide_to(pose({0, 0, 0}, 3.0), 0.01, 5.0, 30.0));
  EXPECT_NEAR(g.step_angular_velocity(1e-3).norm(), 30.0, 1e-9);
  for (int i = 0; i < 100; ++i) g.advance(1e-3);  // 0.1 s of the 0.1 s
  EXPECT_LT((g.pose().matrix() - pose({0, 0, 0}, 3.0).matrix()).norm(), 1e-9);
}

TEST(ObstacleGlide, NewTargetRestartsFromWhereItIs) {
  ObstacleGlide g;
  g.reset(pose({0, 0, 0}, 0.0));
  g.glide_to(pose({0.01, 0, 0}, 0.0), 0.01, 5.0, 30.0);
  for (int i = 0; i < 5; ++i) g.advance(1e-3);  // half way: x = 5 mm
  EXPECT_NEAR(g.pose().translation().x(), 0.005, 1e-12);
  g.glide_to(pose({0.025, 0, 0}, 0.0), 0.01, 5.0, 30.0);  // 20 mm more over 10 ms: 2 m/s
  EXPECT_NEAR(g.step_linear_velocity(1e-3).x(), 2.0, 1e-12);
  // Same pose again (no interval): nothing moves.
  g.reset(pose({0, 0, 0}, 0.0));
  EXPECT_TRUE(g.glide_to(pose({0, 0, 0}, 0.0), 0.0, 5.0, 30.0));
  EXPECT_FALSE(g.moving());
}

}  // namespace
}  // namespace corde_sim
