// The one evaluation of drag per node (model/drag.h): its split along the rod, and that the
// explicit force and the implicit step's matrix are the same drag.
#include "corde_sim/model/drag.h"

#include <gtest/gtest.h>

#include <vector>

#include "corde_sim/rod/rod_shape.h"

namespace corde {
namespace {

Drag air() {
  Drag d;
  d.linear_normal = 0.3;
  d.linear_tangential = 0.05;
  d.quadratic_normal = 1.2;
  d.quadratic_tangential = 0.1;
  return d;
}

// The direction at a node is the chord across it (the end chord at the ends); the normal
// coefficient acts across it, the tangential one along it, each with its quadratic term.
TEST(NodeDrag, SplitsTheVelocityAlongTheChordAcrossTheNode) {
  const std::vector<Vec3> x{Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0)};
  const Drag d = air();
  const Vec3 v(2.0, 0.0, 3.0);
  const NodeDrag end = node_drag(d, x, 0, v, 0.6, 2.0);
  EXPECT_LT((end.tangent - Vec3::UnitX()).norm(), 1e-15);
  EXPECT_LT((end.v_tangential - Vec3(2, 0, 0)).norm(), 1e-15);
  EXPECT_LT((end.v_normal - Vec3(0, 0, 3)).norm(), 1e-15);
  EXPECT_DOUBLE_EQ(end.normal, 0.3 + 1.2 * 3.0);
  EXPECT_DOUBLE_EQ(end.tangential, 0.05 + 0.1 * 2.0);
  EXPECT_DOUBLE_EQ(end.length, 1.2);
  EXPECT_LT((drag_force(end) - 1.2 * Vec3(-0.25 * 2.0, 0.0, -3.9 * 3.0)).norm(), 1e-14);
  const NodeDrag mid = node_drag(d, x, 1, v, 0.6, 2.0);
  EXPECT_LT((mid.tangent - Vec3(1, 1, 0).normalized()).norm(), 1e-15);
  // A node whose chord vanishes has no direction: all of its velocity is normal.
  const std::vector<Vec3> same{Vec3(0, 0, 0), Vec3(0, 0, 0)};
  const NodeDrag none = node_drag(d, same, 0, v, 0.6, 2.0);
  EXPECT_EQ(none.tangent, Vec3::Zero());
  EXPECT_LT((none.v_normal - v).norm(), 1e-15);
}

// The implicit step's matrix with its coefficients held reproduces the explicit force.
TEST(NodeDrag, MatrixTimesVelocityIsMinusTheForce) {
  const std::vector<Vec3> x{Vec3(0, 0, 0), Vec3(0.1, 0.02, -0.01), Vec3(0.15, 0.09, 0.0)};
  for (int i = 0; i < 3; ++i) {
    const Vec3 v(0.4 - i, 0.7, -0.2 * i);
    const NodeDrag n = node_drag(air(), x, i, v, 0.02, 4.0);
    EXPECT_LT((drag_matrix(n) * v + drag_force(n)).norm(), 1e-15 * (1.0 + drag_force(n).norm()));
  }
}

// The rod's force holds each node's drag at the rod's own velocity and per length its mass
// stands for.
TEST(NodeDrag, RodForceIsTheNodesDrag) {
  RodSpec spec;
  spec.elements = 5;
  spec.shape.length = 0.5;
  spec.section.stretch = 10.0;
  spec.section.mass_per_length = 0.2;
  spec.section.inertia_bend = spec.section.inertia_twist = 1e-6;
  Rod rod = build_rod(spec);
  for (int i = 0; i < rod.num_nodes(); ++i) rod.velocities()[i] = Vec3(0.3 * i, -0.5, 0.1 * i * i);
  rod.compute_forces(0.0, Vec3::Zero());
  const std::vector<Vec3> f0 = rod.forces();
  rod.set_drag(air());
  rod.compute_forces(0.0, Vec3::Zero());
  for (int i = 0; i < rod.num_nodes(); ++i) {
    const Vec3 want = drag_force(
        node_drag(air(), rod.positions(), i, rod.velocities()[i], rod.node_masses()[i], 1.0 / 0.2));
    EXPECT_LT((rod.forces()[i] - f0[i] - want).norm(), 1e-14 * (1.0 + f0[i].norm())) << i;
  }
}

}  // namespace
}  // namespace corde
