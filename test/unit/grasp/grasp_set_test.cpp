// The grasp set: refused grasps, offsets that glide, wrenches as external forces, and the
// reaction wrench on the holder checked against momentum balance and statics.
#include "corde_sim/grasp/grasp_set.h"

#include <gtest/gtest.h>

#include <cmath>

#include "corde_sim/statics/statics.h"
#include "dynamics_util.h"
#include "grasp_test_util.h"

namespace corde {
namespace {

// The example rod of dynamics_util.h (1 m along x, r = 1 cm, E = 1e7, rho = 1000) at z = 1, named
// "rod", with Kelvin-Voigt friction of retardation time tau.
World example_world(int elements, double tau) {
  using dyn::example_material;
  using dyn::kPi;
  using dyn::straight_rod;
  Material m = example_material();
  const double area = kPi * 0.01 * 0.01;
  m.gamma_t = tau * 1e7 * area;
  m.gamma_r = tau * 1e7 * area * 0.01 * 0.01 / 4.0;
  Rod rod = straight_rod(m, 0.01, 1.0, elements);
  for (Vec3& x : rod.positions()) x.z() += 1.0;
  World w;
  w.time_step = 1e-5;
  w.add_rod(std::move(rod));
  return w;
}

using corde::test::at_node;

void step(World* w, GraspSet* g, int n) {
  for (int k = 0; k < n; ++k) {
    g->before_step(*w, w->time(), w->time_step, HolderLimits());
    w->step();
    g->after_step(*w, w->time_step);
  }
}

TEST(GraspSet, RefusesHeldSegmentsAndTheirNeighbours) {
  World w = example_world(10, 0.0);
  GraspSet g;
  const Eigen::Isometry3d id = Eigen::Isometry3d::Identity();
  ASSERT_EQ(g.add(w, at_node("a", 5), id, nullptr, 0.0), "");
  EXPECT_NE(g.add(w, at_node("a", 8), id, nullptr, 0.0).find("already holds"), std::string::npos);
  EXPECT_NE(g.add(w, at_node("b", 5), id, nullptr, 0.0).find("already held by grasp 'a'"),
            std::string::npos);
  EXPECT_NE(g.add(w, at_node("b", 4), id, nullptr, 0.0).find("shares node 5"), std::string::npos);
  EXPECT_NE(g.add(w, at_node("b", 6), id, nullptr, 0.0).find("shares node 6"), std::string::npos);
  EXPECT_EQ(g.add(w, at_node("b", 7), id, nullptr, 0.0), "");
  // A boundary condition is not replaced by a grasp.
  w.rods()[0].add_node_drive(NodeDrive{});
  EXPECT_NE(g.add(w, at_node("c", 0), id, nullptr, 0.0).find("boundary condition"),
            std::string::npos);
  EXPECT_NE(g.add(w, at_node("c", 8), id, nullptr, 0.0).find("shares node 8"), std::string::npos);
  GraspSpec other = at_node("c", 2);
  other.rod = "nope";
  EXPECT_NE(g.add(w, other, id, nullptr, 0.0).find("no rod named"), std::string::npos);
  // After a release the segment can be grasped again.
  EXPECT_TRUE(g.release(w, "a"));
  EXPECT_FALSE(g.release(w, "a"));
  EXPECT_EQ(g.add(w, at_node("d", 5), id, nullptr, 0.0), "");
}

TEST(GraspSet, GivenOffsetGlidesInsteadOfJumping) {
  World w = example_world(10, 1e-3);
  w.gravity.setZero();
  GraspSet g;
  Eigen::Isometry3d holder = Eigen::Isometry3d::Identity();
  holder.translation() << 1.2, 0.0, 1.0;  // 0.25 m from the end segment's midpoint
  const Eigen::Isometry3d offset = Eigen::Isometry3d::Identity();
  ASSERT_EQ(g.add(w, at_node("a", 10), holder, &offset, 0.0), "");
  const Vec3 before = w.rods()[0].positions()[10];
  step(&w, &g, 1);
  // One step at the largest linear and angular acceleration (the node is 5 cm from the midpoint).
  const double h2 = w.time_step * w.time_step;
  EXPECT_LT((w.rods()[0].positions()[10] - before).norm(),
            (HolderLimits().max_acceleration + 0.05 * HolderLimits().max_angular_acceleration) *
                h2 * 1.01);
  step(&w, &g, 100000);  // 1 s
  const Eigen::Isometry3d seg = segment_pose(w.rods()[0], 9);
  EXPECT_LT((seg.translation() - holder.translation()).norm(), 1e-9);
}

TEST(GraspSet, WrenchActsLikeALoad) {
  // A wrench on a released grasp pushes the rod exactly as the same loads would.
  World a = example_world(10, 1e-3), b = example_world(10, 1e-3);
  GraspSet g;
  ASSERT_EQ(g.add(a, at_node("a", 4), Eigen::Isometry3d::Identity(), nullptr, 0.0), "");
  ASSERT_TRUE(g.release(a, "a"));
  g.set_wrench(a, "a", Vec3(0, 0.5, 2.0), Vec3(0.01, 0, 0.02));
  Load f;
  f.index = 4;
  f.value = Vec3(0, 0.25, 1.0);
  b.rods()[0].add_load(f);
  f.index = 5;
  b.rods()[0].add_load(f);
  Load t;
  t.kind = Load::Kind::kTorque;
  t.index = 4;
  t.value = Vec3(0.01, 0, 0.02);
  b.rods()[0].add_load(t);
  step(&a, &g, 2000);
  b.step(2000);
  for (int i = 0; i <= 10; ++i)
    EXPECT_LT((a.rods()[0].positions()[i] - b.rods()[0].positions()[i]).norm(), 1e-13);
}

TEST(GraspSet, ReactionsBalanceMomentumWhileMoving) {
  // Newton for the whole rod: the forces on it are gravity, the wrench and the holders', so over
  // any window the reactions on the holders sum to M g + F - dP/dt, to round-off, while the
  // holders move and the rod swings.
  World w = example_world(20, 1e-4);
  GraspSet g;
  const Eigen::Isometry3d id = Eigen::Isometry3d::Identity();
  ASSERT_EQ(g.add(w, at_node("left", 0), id, nullptr, 0.0), "");
  ASSERT_EQ(g.add(w, at_node("right", 20), id, nullptr, 0.0), "");
  ASSERT_EQ(g.add(w, at_node("push", 10), id, nullptr, 0.0), "");
  ASSERT_TRUE(g.release(w, "push"));
  g.set_wrench(w, "push", Vec3(0.3, 0, -0.2), Vec3::Zero());
  Eigen::Isometry3d goal = id;
  goal.translation() << -0.3, 0.1, 0.2;  // left holder moves towards the right one
  g.set_goal("left", 0.0, goal, 0.05);
  step(&w, &g, 1000);
  Vec3 f, t;
  g.take_reaction("left", &f, &t);  // start a new window
  g.take_reaction("right", &f, &t);
  const Vec3 p0 = w.rods()[0].linear_momentum();
  const int n = 3000;
  step(&w, &g, n);
  Vec3 fl, fr;
  ASSERT_TRUE(g.take_reaction("left", &fl, &t));
  ASSERT_TRUE(g.take_reaction("right", &fr, &t));
  double mass = 0.0;
  for (double m : w.rods()[0].node_masses()) mass += m;
  const Vec3 dpdt = (w.rods()[0].linear_momentum() - p0) / (n * w.time_step);
  const Vec3 expected = mass * w.gravity + Vec3(0.3, 0, -0.2) - dpdt;
  EXPECT_GT(dpdt.norm(), 0.1 * mass * 9.81);  // it really moved
  EXPECT_LT((fl + fr - expected).norm(), 1e-9 * mass * 9.81)
      << (fl + fr).transpose() << " vs " << expected.transpose();
}

TEST(GraspSet, ReactionOfAHeldCantileverIsItsWeightAndMoment) {
  // A rod held horizontally at one end by a grasp that holds its orientation, in equilibrium
  // (solved as statics): the holder carries the whole weight and its moment about the holder.
  World w = example_world(20, 0.0);
  GraspSet g;
  ASSERT_EQ(g.add(w, at_node("hand", 0), Eigen::Isometry3d::Identity(), nullptr, 0.0), "");
  Rod& rod = w.rods()[0];
  StaticOptions o;
  o.load_steps = 4;
  const StaticResult r = solve_statics(rod, w.gravity, 0.0, o);
  ASSERT_TRUE(r.converged);
  step(&w, &g, 1);
  Vec3 f, t;
  ASSERT_TRUE(g.take_reaction("hand", &f, &t));
  double mass = 0.0;
  Vec3 moment = Vec3::Zero();
  const Vec3 origin = g.find("hand")->holder.pose().translation();
  for (int i = 0; i < rod.num_nodes(); ++i) {
    mass += rod.node_masses()[i];
    moment += (rod.positions()[i] - origin).cross(rod.node_masses()[i] * w.gravity);
  }
  // The holder is the identity frame: holder frame = world frame.
  EXPECT_LT((f - mass * w.gravity).norm(), 1e-6 * mass * 9.81) << f.transpose();
  EXPECT_LT((t - moment).norm(), 1e-6 * moment.norm())
      << t.transpose() << " vs " << moment.transpose();
  EXPECT_GT(moment.norm(), 0.1);  // about M g L / 2 = 1.5 N m
}

}  // namespace
}  // namespace corde
