// The one evaluation of loads (model/loads.h): frames, potential, and that the explicit force and
// the rod system's gradient both act with it.
#include "corde_sim/model/loads.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <vector>

#include "corde_sim/model/rod_system.h"
#include "corde_sim/rod/rod_shape.h"

namespace corde {
namespace {

std::vector<Quat> turned_frames(int n) {
  std::vector<Quat> q;
  for (int s = 0; s < n; ++s)
    q.push_back(Quat(Eigen::AngleAxisd(0.3 + 0.4 * s, Vec3(1.0, 0.5 * s, -0.2).normalized())));
  return q;
}

TEST(LoadEvaluation, RampRisesFromZeroToFull) {
  const Load l{Load::Kind::kForce, 0, Vec3::UnitZ(), 1.0, 2.0, false};
  EXPECT_EQ(l.scale(0.5), 0.0);
  EXPECT_DOUBLE_EQ(l.scale(2.0), 0.5);
  EXPECT_EQ(l.scale(3.0), 1.0);
  EXPECT_EQ(l.scale(10.0), 1.0);
}

// A follower force on node i turns with segment min(i, N - 1), a follower torque with its own
// segment; dead loads keep their world value. Body and world torques are one torque.
TEST(LoadEvaluation, FollowersTurnWithTheirFrameDeadLoadsDoNot) {
  const std::vector<Quat> q = turned_frames(3);
  const Vec3 value(0.1, -0.2, 0.3);
  const double k = 0.75;
  for (int node = 0; node <= 3; ++node) {
    const Load dead{Load::Kind::kForce, node, value, 0.0, 0.0, false};
    Load follower = dead;
    follower.follower = true;
    EXPECT_EQ(load_frame(follower, 3), std::min(node, 2));
    EXPECT_LT((load_world(dead, k, q) - k * value).norm(), 1e-16);
    EXPECT_LT((load_world(follower, k, q) - k * (q[std::min(node, 2)] * value)).norm(), 1e-15);
  }
  for (int s = 0; s < 3; ++s)
    for (bool f : {false, true}) {
      const Load l{Load::Kind::kTorque, s, value, 0.0, 0.0, f};
      EXPECT_EQ(load_frame(l, 3), s);
      const Vec3 world = f ? Vec3(q[s] * (k * value)) : Vec3(k * value);
      EXPECT_LT((load_world(l, k, q) - world).norm(), 1e-15);
      EXPECT_LT((q[s] * load_body_torque(l, k, q[s]) - world).norm(), 1e-15);
    }
}

// Only a dead force has a potential, and its force is minus the potential's gradient.
TEST(LoadEvaluation, DeadForceIsMinusTheGradientOfItsPotential) {
  const Load l{Load::Kind::kForce, 1, Vec3(0.4, -1.0, 2.0), 0.0, 0.0, false};
  EXPECT_TRUE(load_has_potential(l));
  const std::vector<Quat> q = turned_frames(2);
  const double k = 0.3, e = 1e-3;
  const Vec3 x(0.2, 0.1, -0.5);
  for (int c = 0; c < 3; ++c) {
    const Vec3 dx = e * Vec3::Unit(c);
    const double grad = (-load_work(l, k, x + dx) + load_work(l, k, x - dx)) / (2.0 * e);
    EXPECT_NEAR(-grad, load_world(l, k, q)(c), 1e-12);
  }
  Load follower = l, torque = l;
  follower.follower = true;
  torque.kind = Load::Kind::kTorque;
  EXPECT_FALSE(load_has_potential(follower));
  EXPECT_FALSE(load_has_potential(torque));
  EXPECT_DOUBLE_EQ(load_magnitude(l, k), k * l.value.norm());
}

// The explicit force (Rod::compute_forces) and the rod system's gradient (statics' energy, the
// implicit step's system) take the loads from the same evaluation.
TEST(LoadEvaluation, ExplicitForceAndRodSystemAgree) {
  RodSpec spec;
  spec.elements = 4;
  spec.shape.length = 0.4;
  spec.section.bend = 0.3;
  spec.section.twist = 0.2;
  spec.section.stretch = 50.0;
  spec.section.kappa = 20.0;
  spec.section.mass_per_length = 0.5;
  spec.section.inertia_bend = 1e-4;
  spec.section.inertia_twist = 2e-4;
  Rod rod = build_rod(spec);
  rod.orientations() = turned_frames(4);
  const double t = 0.5;
  rod.compute_forces(t, Vec3::Zero());
  const std::vector<Vec3> f0 = rod.forces(), tau0 = rod.torques();
  const Load force{Load::Kind::kForce, 2, Vec3(0.1, -0.2, 0.3), 0.0, 1.0, false};
  const Load torque{Load::Kind::kTorque, 1, Vec3(-0.05, 0.02, 0.04), 0.0, 1.0, false};
  rod.add_load(force);
  rod.add_load(torque);
  rod.compute_forces(t, Vec3::Zero());
  const double k = force.scale(t);
  const Vec3 want_f = load_world(force, k, rod.orientations());
  const Vec3 want_tau = load_body_torque(torque, k, rod.orientations()[1]);
  // Round-off of the items' other forces and torques (coupling of the turned frames).
  EXPECT_LT((rod.forces()[2] - f0[2] - want_f).norm(), 1e-14 * (1.0 + f0[2].norm()));
  EXPECT_LT((rod.torques()[1] - tau0[1] - want_tau).norm(), 1e-14 * (1.0 + tau0[1].norm()));

  RodSystem sys{&rod, Vec3::Zero(), t, 2.0};  // a load factor of 2 on top of the ramp
  sys.terms = kLoadTerm;
  Eigen::VectorXd g;
  sys.gradient(&g);
  EXPECT_LT((g.segment<3>(RodSystem::node_index(2)) + 2.0 * want_f).norm(), 1e-15);
  EXPECT_LT((g.segment<3>(RodSystem::segment_index(1)) + 2.0 * want_tau).norm(), 1e-15);
  EXPECT_DOUBLE_EQ(sys.energy(), -load_work(force, 2.0 * k, rod.positions()[2]));
}

}  // namespace
}  // namespace corde
