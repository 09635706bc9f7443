// The SO(3) maps of math/so3.h: exp and log inverse to each other at all angles up to pi (both
// sides of their series' branches), the double cover, the skew matrix, and the right Jacobian and
// its inverse transpose against finite differences.
#include "corde_sim/math/so3.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace corde {
namespace {

constexpr double kPi = 3.14159265358979323846;

Vec3 random_axis(std::mt19937* rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  return Vec3(n(*rng), n(*rng), n(*rng)).normalized();
}

// Angles on both sides of the series' branches (exp: 0.2 rad; log: tan of the half angle 0.1,
// 0.1993 rad), tiny ones, and up to just below pi.
const double kAngles[] = {1e-12,     1e-6, 1e-3, 0.1, 0.1992, 0.1994,    0.1999999,
                          0.2000001, 0.5,  1.0,  2.0, 3.0,    kPi - 1e-6};

TEST(So3, ExpAndLogAreInverse) {
  std::mt19937 rng(7);
  for (double a : kAngles)
    for (int k = 0; k < 20; ++k) {
      const Vec3 theta = a * random_axis(&rng);
      for (const Quat& q : {so3::exp(theta), so3::exp_exact(theta)}) {
        EXPECT_NEAR(q.norm(), 1.0, 1e-15) << a;
        EXPECT_LT((so3::log(q) - theta).norm(), 4e-16 * std::max(1.0, a) + 1e-15 * a) << a;
        EXPECT_LT((so3::log_exact(q) - theta).norm(), 4e-16 * std::max(1.0, a) + 1e-15 * a) << a;
        // The other quaternion of the same rotation gives the same rotation vector.
        const Quat neg(-q.w(), -q.x(), -q.y(), -q.z());
        EXPECT_LT((so3::log(neg) - so3::log(q)).norm(), 1e-15) << a;
      }
    }
}

// The series equal the closed forms to round-off, on either side of the branch.
TEST(So3, SeriesMatchTheClosedForms) {
  std::mt19937 rng(11);
  for (double a : kAngles)
    for (int k = 0; k < 20; ++k) {
      const Vec3 theta = a * random_axis(&rng);
      const Quat fast = so3::exp(theta), exact = so3::exp_exact(theta);
      EXPECT_LT((fast.coeffs() - exact.coeffs()).norm(), 3e-16) << a;
      EXPECT_LT((so3::log(exact) - so3::log_exact(exact)).norm(), 2e-16 * std::max(1.0, a)) << a;
    }
  EXPECT_EQ(so3::exp(Vec3::Zero()).coeffs(), Quat::Identity().coeffs());
  EXPECT_EQ(so3::exp_exact(Vec3::Zero()).coeffs(), Quat::Identity().coeffs());
  EXPECT_EQ(so3::log(Quat::Identity()), Vec3::Zero());
  EXPECT_EQ(so3::log_exact(Quat::Identity()), Vec3::Zero());
}

// A turn by pi has two rotation vectors (+-pi a): log gives one of them, of length pi.
TEST(So3, HalfTurn) {
  std::mt19937 rng(3);
  for (int k = 0; k < 20; ++k) {
    const Vec3 a = random_axis(&rng);
    for (const Quat& q : {so3::exp(kPi * a), so3::exp_exact(kPi * a)}) {
      const Vec3 v = so3::log(q);
      EXPECT_NEAR(v.norm(), kPi, 1e-15);
      EXPECT_NEAR(std::abs(v.normalized().dot(a)), 1.0, 1e-15);
      EXPECT_LT((so3::log_exact(q) - v).norm(), 1e-15);
    }
  }
  // Turned past pi: the shorter way round, the other side.
  const Vec3 past = (kPi + 0.5) * Vec3::UnitZ();
  EXPECT_LT((so3::log(so3::exp(past)) - (0.5 - kPi) * Vec3::UnitZ()).norm(), 1e-14);
}

TEST(So3, SkewIsTheCrossProduct) {
  std::mt19937 rng(5);
  for (int k = 0; k < 10; ++k) {
    const Vec3 v = 3.0 * random_axis(&rng), y = random_axis(&rng);
    EXPECT_LT((so3::skew(v) * y - v.cross(y)).norm(), 1e-15);
    EXPECT_EQ(so3::skew(v).transpose(), -so3::skew(v));
  }
}

// exp(theta + e d) = exp(theta) exp(J_r(theta) e d) + O(e^2): J_r d by central differences of
// log(exp(theta)^-1 exp(theta + e d)) / e (1e-8), at angles on both sides of its series' branch
// (1e-4 rad), up to 3 rad. And the inverse transpose inverts it: J_r^T (J_r^-T y) = y (1e-12).
TEST(So3, RightJacobianMatchesDifferences) {
  std::mt19937 rng(13);
  const double e = 1e-6;
  for (double a : {0.0, 1e-5, 0.9999e-4, 1.0001e-4, 0.1, 0.29, 0.31, 1.0, 3.0})
    for (int k = 0; k < 10; ++k) {
      const Vec3 theta = a * random_axis(&rng), d = random_axis(&rng);
      const Quat q = so3::exp_exact(theta);
      const Vec3 plus = so3::log_exact(q.conjugate() * so3::exp_exact(theta + e * d));
      const Vec3 minus = so3::log_exact(q.conjugate() * so3::exp_exact(theta - e * d));
      const Vec3 fd = (plus - minus) / (2.0 * e);
      const Mat3 j = so3::right_jacobian(theta);
      EXPECT_LT((j * d - fd).norm(), 1e-8) << a;
      const Vec3 y = random_axis(&rng);
      EXPECT_LT((j.transpose() * so3::inv_right_jacobian_t(theta, y) - y).norm(), 1e-12) << a;
    }
}

}  // namespace
}  // namespace corde
