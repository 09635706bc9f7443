// Keyframed drives and their state at a step's end, sliding and hinge constraints and follower
// loads on a rod.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>

#include "corde_sim/rod/rod_shape.h"
#include "corde_sim/world/world.h"

namespace corde {
namespace {

constexpr double kPi = 3.14159265358979323846;

World cable(int elements = 20, double damping_time = 0.0) {
  Material m;
  m.youngs_modulus = m.stretch_modulus = 1e7;
  m.shear_modulus = 1e7 / 3.0;
  m.density = 1000.0;
  const double r = 0.005;
  m.kappa = m.shear_modulus * kPi * r * r;
  RodSpec spec;
  spec.elements = elements;
  spec.section = make_section(m, r);
  spec.section.gamma_t = damping_time * spec.section.stretch;
  spec.section.gamma_r = damping_time * spec.section.bend;
  spec.shape.direction = Vec3::UnitX();
  spec.shape.length = 0.5;
  World w;
  w.time_step = 2e-5;
  w.add_rod(build_rod(spec));
  return w;
}

// A keyframed node lands on its keyframes exactly at the steps that end there, with the motion's
// velocity, and holds the last one.
TEST(KeyframedDrive, NodeReachesAndHoldsKeyframes) {
  World w = cable();
  Rod& rod = w.rods()[0];
  const Vec3 x0 = rod.positions()[0];
  auto motion = std::make_shared<Motion>(
      std::vector<Keyframe>{{0.01, Vec3(0.0, 0.0, 0.05), Quat::Identity(), 0.0},
                            {0.02, Vec3(0.05, 0.02, 0.05), Quat::Identity(), 0.0}},
      Motion::Interpolation::kSmooth);
  NodeDrive d;
  d.kind = NodeDrive::Kind::kMotion;
  d.node = 0;
  d.origin = d.pivot = x0;
  d.motion = motion;
  rod.add_node_drive(d);
  w.time_step = 1e-4;
  for (int i = 1; i <= 300; ++i) {
    w.step();
    const Motion::Sample s = motion->at(w.time());
    EXPECT_LT((rod.positions()[0] - (x0 + s.displacement)).norm(), 1e-15) << i;
    EXPECT_LT((rod.velocities()[0] - s.velocity).norm(), 1e-12) << i;
    if (i == 100) {
      EXPECT_LT((rod.positions()[0] - x0 - Vec3(0.0, 0.0, 0.05)).norm(), 1e-14);
    }
    if (i >= 200) {
      EXPECT_LT((rod.positions()[0] - x0 - Vec3(0.05, 0.02, 0.05)).norm(), 1e-14);
    }
  }
}

// A segment turned by keyframes about its tangent, and a moving ghost frame, follow their
// motions' rotations.
TEST(KeyframedDrive, SegmentAndGhostFrameTurn) {
  World w = cable();
  Rod& rod = w.rods()[0];
  const int n = rod.num_segments();
  const Quat q0 = rod.orientations()[0];
  const Vec3 t0 = q0 * Vec3::UnitZ();
  auto turns = std::make_shared<Motion>(Motion::ramp(0.0, 0.01, Vec3::Zero(), 2 * kPi * 1.25, t0));
  SegmentDrive d;
  d.kind = SegmentDrive::Kind::kMotion;
  d.segment = 0;
  d.origin = q0;
  d.motion = turns;
  rod.add_segment_drive(d);
  GhostFrame& g = rod.ghost_end();
  g.active = true;
  g.frame = g.origin = rod.orientations()[n - 1];
  g.motion = turns;
  w.time_step = 1e-5;
  w.step(2000);
  const Quat want = Quat(Eigen::AngleAxisd(2 * kPi * 1.25, t0)) * q0;
  EXPECT_LT(std::abs(std::abs(rod.orientations()[0].coeffs().dot(want.coeffs())) - 1.0), 1e-14);
  EXPECT_LT(rod.angular_velocities()[0].norm(), 1e-12);
  const Quat want_end = Quat(Eigen::AngleAxisd(2 * kPi * 1.25, t0)) * g.origin;
  EXPECT_LT(std::abs(std::abs(g.frame.coeffs().dot(want_end.coeffs())) - 1.0), 1e-14);
}

// A node on a slanted line moves only along it while the rod falls and swings; a node on a plane
// stays in it; both move (the constraint does not freeze them).
TEST(Constraints, LineAndPlaneHoldOnlyAcross) {
  World w = cable();
  Rod& rod = w.rods()[0];
  const int n = rod.num_segments();
  NodeConstraint line;
  line.node = 0;
  line.point = rod.positions()[0];
  line.direction = Vec3(1.0, 0.5, -0.3);
  rod.add_node_constraint(line);
  NodeConstraint plane;
  plane.kind = NodeConstraint::Kind::kPlane;
  plane.node = n;
  plane.point = rod.positions()[n];
  plane.direction = Vec3(0.2, 0.0, 1.0);
  rod.add_node_constraint(plane);
  const Vec3 a = line.direction.normalized(), nrm = plane.direction.normalized();
  double max_off_line = 0.0, max_off_plane = 0.0;
  for (int i = 0; i < 5000; ++i) {
    w.step();
    const Vec3 r = rod.positions()[0] - line.point;
    max_off_line = std::max(max_off_line, (r - a * a.dot(r)).norm());
    max_off_plane = std::max(max_off_plane, std::abs(nrm.dot(rod.positions()[n] - plane.point)));
    EXPECT_LT((rod.velocities()[0] - a * a.dot(rod.velocities()[0])).norm(), 1e-12);
  }
  EXPECT_LT(max_off_line, 1e-14);
  EXPECT_LT(max_off_plane, 1e-14);
  EXPECT_GT((rod.positions()[0] - line.point).norm(), 1e-3);
  EXPECT_GT((rod.positions()[n] - plane.point).norm(), 1e-3);
  EXPECT_THROW(rod.add_node_drive(NodeDrive{}), std::invalid_argument);  // node 0: constrained
}

// A hinge lets a segment turn about its axis only: a torque about the tangent spins it, one
// across it is carried by the hinge.
TEST(Constraints, HingeTurnsAboutItsAxisOnly) {
  World w = cable();
  w.gravity.setZero();
  Rod& rod = w.rods()[0];
  const int s = rod.num_segments() - 1;
  SegmentConstraint c;
  c.segment = s;
  c.origin = rod.orientations()[s];
  c.axis = c.origin * Vec3::UnitZ();
  rod.add_segment_constraint(c);
  Load torque;
  torque.kind = Load::Kind::kTorque;
  torque.index = s;
  torque.value = 1e-4 * c.axis + Vec3(0.0, 2e-4, 1e-4);
  rod.add_load(torque);
  w.step(3000);
  const Quat rel = rod.orientations()[s] * c.origin.conjugate();
  EXPECT_LT((rel.vec() - c.axis * c.axis.dot(rel.vec())).norm(), 1e-12);
  EXPECT_GT(std::abs(rel.vec().dot(c.axis)), 1e-3);  // it turned
  const Vec3 omega = rod.orientations()[s] * rod.angular_velocities()[s];
  EXPECT_LT((omega - c.axis * c.axis.dot(omega)).norm(), 1e-12);
}

// A target drive reaches its target over the step: a node at (target - x) / h, a segment turned
// the short way, its body and world angular velocities one rotation.
TEST(DriveState, TargetsAreReachedOverTheStep) {
  const double h = 0.01;
  NodeDrive nd;
  nd.kind = NodeDrive::Kind::kTarget;
  nd.target = Vec3(0.1, -0.2, 0.3);
  const Vec3 x(0.1, -0.2, 0.25);
  const DrivenNode n = drive_state(nd, 1.0, h, x);
  EXPECT_EQ(n.position, nd.target);
  EXPECT_LT((x + h * n.velocity - nd.target).norm(), 1e-15);

  SegmentDrive sd;
  sd.kind = SegmentDrive::Kind::kTarget;
  const Quat q(Eigen::AngleAxisd(0.4, Vec3(0.2, 1.0, 0.0).normalized()));
  const Quat turn(Eigen::AngleAxisd(0.3, Vec3(1.0, 0.0, 0.5).normalized()));
  sd.target.coeffs() = -2.0 * (q * turn).coeffs();  // not unit, and on the other hemisphere
  const DrivenSegment s = drive_state(sd, 1.0, h, q);
  EXPECT_GT(s.orientation.coeffs().dot(q.coeffs()), 0.0);
  EXPECT_LT((s.orientation.coeffs() - (q * turn).coeffs()).norm(), 1e-15);
  const Vec3 body = h * s.angular_velocity;
  const Quat reached = q * Quat(Eigen::AngleAxisd(body.norm(), body.normalized()));
  EXPECT_LT((reached.coeffs() - s.orientation.coeffs()).norm(), 1e-14);
  EXPECT_LT((s.world_angular_velocity - q * s.angular_velocity).norm(), 1e-15);
  EXPECT_NEAR(body.norm(), 0.3, 1e-14);
}

// The other drives give their own state at the step's end, whatever the state at its start.
TEST(DriveState, OtherDrivesGiveTheirOwnState) {
  NodeDrive nd;
  nd.kind = NodeDrive::Kind::kVelocity;
  nd.origin = Vec3(1.0, 0.0, 0.0);
  nd.velocity = Vec3(0.0, 0.5, 0.0);
  Vec3 v;
  const Vec3 x = drive_position(nd, 2.0, &v);
  const DrivenNode n = drive_state(nd, 2.0, 0.01, Vec3(5.0, 5.0, 5.0));
  EXPECT_EQ(n.position, x);
  EXPECT_EQ(n.velocity, v);

  SegmentDrive sd;
  sd.kind = SegmentDrive::Kind::kSpin;
  sd.origin = Quat(Eigen::AngleAxisd(0.4, Vec3::UnitY()));
  sd.rate = 3.0;
  Vec3 w;
  const Quat q = drive_orientation(sd, 0.5, &w);
  const DrivenSegment s = drive_state(sd, 0.5, 0.01, Quat::Identity());
  EXPECT_EQ(s.orientation.coeffs(), q.coeffs());
  EXPECT_EQ(s.world_angular_velocity, w);
  EXPECT_LT((q * s.angular_velocity - w).norm(), 1e-14);
  // drive_orientation_near only chooses the sign.
  const Quat near = drive_orientation_near(sd, 0.5, Quat(-q.coeffs()));
  EXPECT_EQ(near.coeffs(), -q.coeffs());
}

// A dead load keeps its world direction; a follower load turns with its segment.
TEST(Loads, FollowerTurnsWithTheSegmentDeadDoesNot) {
  World w = cable();
  Rod& rod = w.rods()[0];
  const int n = rod.num_segments();
  rod.orientations()[n - 1] =
      Quat(Eigen::AngleAxisd(0.7, Vec3(0.3, 1.0, 0.2).normalized())) * rod.orientations()[n - 1];
  rod.compute_forces(0.0, w.gravity);
  const std::vector<Vec3> f0 = rod.forces(), tau0 = rod.torques();
  const Vec3 value(0.1, -0.2, 0.3);
  for (bool follower : {false, true}) {
    rod.loads().clear();
    rod.add_load(Load{Load::Kind::kForce, n, value, 0.0, 0.0, follower});
    rod.add_load(Load{Load::Kind::kTorque, n - 1, value, 0.0, 0.0, follower});
    rod.compute_forces(0.0, w.gravity);
    const Quat& q = rod.orientations()[n - 1];
    const Vec3 want_f = follower ? Vec3(q * value) : value;
    const Vec3 want_tau = follower ? value : Vec3(q.conjugate() * value);  // body frame
    // Round-off of the node's other forces (about 1 N of stretch and coupling).
    EXPECT_LT((rod.forces()[n] - f0[n] - want_f).norm(), 1e-12);
    EXPECT_LT((rod.torques()[n - 1] - tau0[n - 1] - want_tau).norm(), 1e-12);
  }
}

}  // namespace
}  // namespace corde
