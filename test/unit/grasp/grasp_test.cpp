// Grasps: resolving a place on a rod, following a holder, twisting, releasing.
#include "corde_sim/grasp/grasp.h"

#include <gtest/gtest.h>

#include <cmath>

#include "corde_sim/rod/rod_shape.h"

namespace corde {
namespace {

constexpr double kPi = 3.14159265358979323846;

// The example rod of docs/validation_references.md (L = 1, r = 1 cm, E = 1e7, G = E/3) along x,
// with internal friction so that quasi-static motions settle.
Rod example_rod(int elements, double tau) {
  Material m;
  m.youngs_modulus = 1e7;
  m.shear_modulus = 1e7 / 3.0;
  m.stretch_modulus = 1e7;
  m.density = 1000.0;
  const double r = 0.01, area = kPi * r * r;
  m.kappa = m.shear_modulus * area;
  m.gamma_t = tau * 1e7 * area;
  m.gamma_r = tau * 1e7 * area * r * r / 4.0;
  RodSpec spec;
  spec.elements = elements;
  spec.section = make_section(m, r);
  return build_rod(spec);
}

void clamp_start(Rod* rod) {
  rod->add_node_drive(NodeDrive{});
  SegmentDrive s;
  s.origin = rod->orientations()[0];
  rod->add_segment_drive(s);
}

TEST(Grasp, ResolvesPlaces) {
  const Rod rod = example_rod(10, 0.0);  // segments of 0.1 m
  GraspSpec g;
  g.place = GraspSpec::Place::kStart;
  EXPECT_EQ(grasp_segment(rod, g), 0);
  g.place = GraspSpec::Place::kEnd;
  EXPECT_EQ(grasp_segment(rod, g), 9);
  g.place = GraspSpec::Place::kNode;
  g.value = 4;
  EXPECT_EQ(grasp_segment(rod, g), 4);
  g.value = 10;  // the last node belongs to the last segment
  EXPECT_EQ(grasp_segment(rod, g), 9);
  g.place = GraspSpec::Place::kArcLength;
  g.value = 0.33;  // midpoints at 0.05, 0.15, ...: nearest is 0.35
  EXPECT_EQ(grasp_segment(rod, g), 3);
  g.value = 0.0;
  EXPECT_EQ(grasp_segment(rod, g), 0);
  g.value = 1.0;
  EXPECT_EQ(grasp_segment(rod, g), 9);
}

TEST(Grasp, MakeGraspDoesNotMoveTheRod) {
  Rod rod = example_rod(10, 0.0);
  GraspSpec spec;
  Eigen::Isometry3d holder = Eigen::Isometry3d::Identity();
  holder.translation() = Vec3(0.3, -0.2, 0.5);
  holder.linear() = Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()).toRotationMatrix();
  const Grasp g = make_grasp(rod, spec, holder);
  const std::vector<Vec3> before = rod.positions();
  const Eigen::Isometry3d before_pose = segment_pose(rod, 9);
  hold(rod, g, holder);
  rod.step(0.0, 1e-5, Vec3::Zero());
  for (int i = 0; i <= 10; ++i) EXPECT_LT((rod.positions()[i] - before[i]).norm(), 1e-12) << i;
  EXPECT_LT(rod.orientations()[9].angularDistance(Quat(before_pose.linear())), 1e-12);
}

TEST(Grasp, PlaceRodMovesItRigidlyOntoThePose) {
  Rod rod = example_rod(10, 0.0);
  // A bent, moving rod: its shape and speeds must come along unchanged.
  for (int i = 0; i <= 10; ++i) {
    rod.positions()[i].z() += 0.02 * std::sin(0.5 * i);
    rod.velocities()[i] = Vec3(0.1, -0.2 * i, 0.05);
  }
  for (int s = 0; s < 10; ++s)
    rod.orientations()[s] =
        (rod.orientations()[s] * Quat(Eigen::AngleAxisd(0.1 * s, Vec3::UnitZ()))).normalized();
  const Rod before = rod;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation() = Vec3(0.4, -0.2, 1.3);
  pose.linear() = Eigen::AngleAxisd(2.5, Vec3(1, -2, 0.5).normalized()).toRotationMatrix();
  place_rod(rod, 3, pose);
  const Eigen::Isometry3d got = segment_pose(rod, 3);
  EXPECT_LT((got.translation() - pose.translation()).norm(), 1e-12);
  EXPECT_LT(Quat(got.linear()).angularDistance(Quat(pose.linear())), 1e-12);
  // Rigid: distances between nodes, the elastic energy and the kinetic energy are unchanged.
  const Vec3 g = Vec3::Zero();
  EXPECT_NEAR(rod.energies(g).elastic(), before.energies(g).elastic(),
              1e-9 * before.energies(g).elastic());
  EXPECT_NEAR(rod.energies(g).kinetic(), before.energies(g).kinetic(),
              1e-12 * before.energies(g).kinetic());
  for (int i = 0; i < 10; ++i)
    EXPECT_NEAR((rod.positions()[i + 1] - rod.positions()[0]).norm(),
                (before.positions()[i + 1] - before.positions()[0]).norm(), 1e-12);
}

TEST(Grasp, HeldEndFollowsMovedHolder) {
  Rod rod = example_rod(20, 1e-3);
  clamp_start(&rod);
  GraspSpec spec;
  const Eigen::Isometry3d start = segment_pose(rod, 19);
  const Grasp g = make_grasp(rod, spec, start);
  const double h = 2e-5;
  Eigen::Isometry3d holder = start;
  // Move the holder 0.2 m sideways and 0.1 m back over 0.5 s, turning it by 30 degrees.
  const int steps = 25000;
  for (int i = 1; i <= steps; ++i) {
    const double s = static_cast<double>(i) / steps;
    holder = start;
    holder.translation() += s * Vec3(-0.1, 0.2, 0.0);
    holder.linear() = Eigen::AngleAxisd(s * kPi / 6, Vec3::UnitZ()) * start.linear();
    hold(rod, g, holder);
    rod.step((i - 1) * h, h, Vec3::Zero());
  }
  const Eigen::Isometry3d seg = segment_pose(rod, 19);
  EXPECT_LT((seg.translation() - holder.translation()).norm(), 1e-9);
  EXPECT_LT(Quat(seg.linear()).angularDistance(Quat(holder.linear())), 1e-9);
  // Its nodes are half a rest length either side of the midpoint along d3.
  const Vec3 d3 = holder.linear().col(2);
  EXPECT_LT((rod.positions()[20] - (holder.translation() + 0.025 * d3)).norm(), 1e-9);
  // The rod between bends: its middle left the x axis.
  EXPECT_GT(std::abs(rod.positions()[10].y()), 0.02);
  EXPECT_TRUE(rod.finite());
}

TEST(Grasp, RotatingHolderAboutTangentTwistsTheRod) {
  // Natural clamp at the start, grasp on the last segment turned by phi about the tangent: the
  // relative rotation of segments 0 and N-1 is phi, spread over N-1 elements of length l, so in
  // equilibrium u3 = phi / ((N-1) l) everywhere and the energy is C phi^2 / (2 (N-1) l).
  const int n = 10;
  Rod rod = example_rod(n, 2e-3);
  clamp_start(&rod);
  const Eigen::Isometry3d start = segment_pose(rod, n - 1);
  const Grasp g = make_grasp(rod, GraspSpec{}, start);
  const double phi = 0.5, h = 5e-5;
  const int ramp = 4000, settle = 16000;
  for (int i = 1; i <= ramp + settle; ++i) {
    const double s = std::min(1.0, static_cast<double>(i) / ramp);
    Eigen::Isometry3d holder = start;
    holder.linear() = start.linear() * Eigen::AngleAxisd(s * phi, Vec3::UnitZ()).toRotationMatrix();
    hold(rod, g, holder);
    rod.step((i - 1) * h, h, Vec3::Zero());
  }
  const double l = 1.0 / n, expected = phi / ((n - 1) * l);
  for (int j = 0; j + 1 < n; ++j) {
    const Vec3 u = darboux(rod.orientations()[j], rod.orientations()[j + 1], l);
    EXPECT_NEAR(u.z(), expected, 1e-3 * expected) << "element " << j;
    EXPECT_NEAR(u.head<2>().norm(), 0.0, 1e-6) << "element " << j;
  }
  const double twist_energy = rod.section().twist * phi * phi / (2.0 * (n - 1) * l);
  EXPECT_NEAR(rod.energies(Vec3::Zero()).bend_twist, twist_energy, 1e-3 * twist_energy);
}

TEST(Grasp, ReleaseKeepsPositionsAndVelocitiesContinuous) {
  Rod rod = example_rod(20, 1e-3);
  const Eigen::Isometry3d start = segment_pose(rod, 19);
  const Grasp g = make_grasp(rod, GraspSpec{}, start);
  const double h = 2e-5;
  const Vec3 vel(0.0, 0.5, 0.0);  // the holder moves at 0.5 m/s
  int i = 1;
  for (; i <= 2000; ++i) {
    Eigen::Isometry3d holder = start;
    holder.translation() += (i * h) * vel;
    hold(rod, g, holder);
    rod.step((i - 1) * h, h, Vec3::Zero());
  }
  EXPECT_LT((rod.velocities()[20] - vel).norm(), 1e-9);
  release(rod, g);
  EXPECT_EQ(rod.node_drive(19), nullptr);
  EXPECT_EQ(rod.node_drive(20), nullptr);
  EXPECT_EQ(rod.segment_drive(19), nullptr);
  const Vec3 x = rod.positions()[20];
  rod.step((i - 1) * h, h, Vec3::Zero());
  // One free step later the end has moved on by about h v (the rod behind it pulls it only a
  // little in one step) and its velocity changed by a small amount.
  EXPECT_LT((rod.positions()[20] - (x + h * vel)).norm(), 0.05 * h * vel.norm());
  EXPECT_LT((rod.velocities()[20] - vel).norm(), 0.05 * vel.norm());
}

TEST(Grasp, ReleaseKeepsOtherDrives) {
  Rod rod = example_rod(10, 0.0);
  NodeDrive fixed;  // node 0 fixed, a grasp on segment 1 (nodes 1 and 2)
  rod.add_node_drive(fixed);
  GraspSpec spec;
  spec.place = GraspSpec::Place::kNode;
  spec.value = 1;
  const Grasp g = make_grasp(rod, spec, Eigen::Isometry3d::Identity());
  hold(rod, g, Eigen::Isometry3d::Identity());
  ASSERT_NE(rod.node_drive(2), nullptr);
  release(rod, g);
  EXPECT_NE(rod.node_drive(0), nullptr);
  EXPECT_EQ(rod.node_drive(1), nullptr);
  EXPECT_EQ(rod.node_drive(2), nullptr);
}

TEST(Grasp, WithoutOrientationOnlyNodesAreHeld) {
  Rod rod = example_rod(10, 0.0);
  GraspSpec spec;
  spec.hold_orientation = false;
  const Grasp g = make_grasp(rod, spec, Eigen::Isometry3d::Identity());
  hold(rod, g, Eigen::Isometry3d::Identity());
  EXPECT_NE(rod.node_drive(9), nullptr);
  EXPECT_NE(rod.node_drive(10), nullptr);
  EXPECT_EQ(rod.segment_drive(9), nullptr);
}

}  // namespace
}  // namespace corde
