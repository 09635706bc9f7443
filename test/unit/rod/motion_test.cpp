// Keyframed motions: keyframes reached and held, continuity of the interpolation, invalid input.
#include "corde_sim/rod/motion.h"

#include <gtest/gtest.h>

#include <cmath>

namespace corde {
namespace {

Keyframe frame(double t, const Vec3& d, double turns = 0.0, const Quat& r = Quat::Identity()) {
  return Keyframe{t, d, r, 2.0 * M_PI * turns, false, false};
}

Motion waypoints(Motion::Interpolation how) {
  return Motion({frame(0.5, Vec3(0.0, 0.0, 0.2), 1.0), frame(1.2, Vec3(0.3, 0.0, 0.25), 3.5),
                 frame(2.0, Vec3(0.5, 0.1, 0.0), 27.0,
                       Quat(Eigen::AngleAxisd(1.0, Vec3(1.0, 2.0, 0.5).normalized())))},
                how, Vec3(0.0, 1.0, 0.0));
}

const Motion::Interpolation kAll[] = {Motion::Interpolation::kSmooth, Motion::Interpolation::kStop,
                                      Motion::Interpolation::kLinear};

TEST(Motion, ReachesEveryKeyframeAndHoldsTheLast) {
  for (Motion::Interpolation how : kAll) {
    const Motion m = waypoints(how);
    ASSERT_EQ(m.keyframes().size(), 4u);  // the start pose at t = 0 was added
    for (const Keyframe& k : m.keyframes()) {
      const Motion::Sample s = m.at(k.time);
      EXPECT_LT((s.displacement - k.displacement).norm(), 1e-14) << k.time;
      const Quat want = k.rotation * Quat(Eigen::AngleAxisd(k.angle, Vec3::UnitY()));
      EXPECT_LT(std::abs(std::abs(s.rotation.coeffs().dot(want.coeffs())) - 1.0), 1e-14);
    }
    for (double t : {2.0, 2.5, 100.0}) {
      const Motion::Sample s = m.at(t);
      EXPECT_LT((s.displacement - Vec3(0.5, 0.1, 0.0)).norm(), 1e-15);
      EXPECT_EQ(s.velocity.norm(), 0.0);
      EXPECT_EQ(s.angular_velocity.norm(), 0.0);
    }
    const Motion::Sample before = m.at(-1.0);
    EXPECT_EQ(before.displacement.norm(), 0.0);
    EXPECT_EQ(before.velocity.norm(), 0.0);
  }
}

// The velocities are the derivatives of the poses (central differences agree to O(dt^2)), and
// smooth/stop have no velocity jump at any keyframe (C1); linear does.
TEST(Motion, VelocitiesAreDerivativesAndContinuous) {
  const double dt = 1e-6;
  for (Motion::Interpolation how : kAll) {
    const Motion m = waypoints(how);
    for (double t = 0.013; t < 2.0; t += 0.0517) {
      const Motion::Sample a = m.at(t - dt), b = m.at(t + dt), s = m.at(t);
      EXPECT_LT(((b.displacement - a.displacement) / (2 * dt) - s.velocity).norm(), 1e-6) << t;
      const Eigen::AngleAxisd turn(b.rotation * a.rotation.conjugate());
      const Vec3 omega = turn.axis() * turn.angle() / (2 * dt);
      EXPECT_LT((omega - s.angular_velocity).norm(), 1e-5 * (1.0 + omega.norm())) << t;
    }
    for (const Keyframe& k : m.keyframes()) {
      const Motion::Sample l = m.at(k.time - 1e-9), r = m.at(k.time + 1e-9);
      const double jump = (l.velocity - r.velocity).norm();
      if (how == Motion::Interpolation::kLinear)
        EXPECT_GT(jump, 0.1) << k.time;
      else
        EXPECT_LT(jump, 1e-6) << k.time;
    }
  }
  // At rest at every keyframe with stop; through interior ones without stopping with smooth.
  EXPECT_LT(waypoints(Motion::Interpolation::kStop).at(1.2).velocity.norm(), 1e-15);
  EXPECT_GT(waypoints(Motion::Interpolation::kSmooth).at(1.2).velocity.norm(), 0.1);
}

TEST(Motion, RampMovesThenHolds) {
  const Motion m = Motion::ramp(0.5, 2.0, Vec3(0.0, 0.0, -3.0), 2.0 * M_PI * 27.0, Vec3::UnitZ());
  EXPECT_EQ(m.at(0.4).displacement.norm(), 0.0);
  EXPECT_NEAR(m.at(1.5).displacement.z(), -1.5, 1e-14);  // half way (symmetric profile)
  const Motion::Sample end = m.at(2.5);
  EXPECT_NEAR(end.displacement.z(), -3.0, 1e-14);
  EXPECT_LT(m.at(2.5 - 1e-9).velocity.norm(), 1e-6);
  // 27 turns are 27 turns, not an identity rotation: the angular velocity integrates to them.
  double angle = 0.0;
  const int n = 20000;
  for (int i = 0; i < n; ++i) angle += m.at(0.5 + (i + 0.5) * 2.0 / n).angular_velocity.z();
  EXPECT_NEAR(angle * 2.0 / n, 2.0 * M_PI * 27.0, 1e-6);
}

TEST(Motion, RefusesInvalidKeyframes) {
  using I = Motion::Interpolation;
  EXPECT_THROW(Motion({frame(1.0, Vec3::Zero()), frame(1.0, Vec3::UnitX())}, I::kSmooth),
               std::invalid_argument);
  EXPECT_THROW(Motion({frame(-1.0, Vec3::Zero())}, I::kSmooth), std::invalid_argument);
  EXPECT_THROW(Motion({frame(0.0, Vec3::UnitX())}, I::kSmooth), std::invalid_argument);
  EXPECT_THROW(Motion({frame(NAN, Vec3::UnitX())}, I::kSmooth), std::invalid_argument);
  EXPECT_THROW(Motion({frame(1.0, Vec3(INFINITY, 0, 0))}, I::kSmooth), std::invalid_argument);
  EXPECT_THROW(Motion({frame(1.0, Vec3::UnitX())}, I::kSmooth, Vec3::Zero()),
               std::invalid_argument);
  EXPECT_THROW(Motion::ramp(0.0, 0.0, Vec3::UnitX(), 0.0, Vec3::UnitZ()), std::invalid_argument);
  EXPECT_NO_THROW(Motion({frame(0.0, Vec3::Zero()), frame(1.0, Vec3::UnitX())}, I::kSmooth));
}

}  // namespace
}  // namespace corde
