// A line constraint that moves (NodeConstraint::velocity, as a slipping grasp's): the node stays on
// the line and takes its velocity across it under every integrator; removing the constraint frees
// the node.
#include <gtest/gtest.h>

#include "corde_sim/rod/material.h"
#include "corde_sim/rod/rod_shape.h"
#include "corde_sim/world/world.h"

namespace corde {
namespace {

TEST(MovingConstraint, NodeFollowsTheLineAcrossIt) {
  for (Integrator integrator : {Integrator::kSemiImplicitEuler, Integrator::kSplitRotation,
                                Integrator::kImplicitEuler, Integrator::kBdf2}) {
    SCOPED_TRACE(integrator_name(integrator));
    RodSpec spec;
    spec.elements = 10;
    spec.shape.length = 0.5;
    spec.section = make_section(material_preset("paper_rope").material, 0.01);
    World w;
    w.integrator = integrator;
    w.time_step = is_implicit(integrator) ? 1e-4 : 1e-5;
    Rod& rod = w.add_rod(build_rod(spec));
    // Node 0 on a line along x that moves along y and z at u.
    const Vec3 p0 = rod.positions()[0], u(0.0, 0.05, -0.02);
    NodeConstraint c;
    c.node = 0;
    c.direction = Vec3::UnitX();
    c.velocity = u;
    for (int k = 0; k < 2000; ++k) {
      c.point = p0 + (w.time() + w.time_step) * u;  // where the line is at the step's end
      rod.add_node_constraint(c);
      w.step();
      const Vec3 off = rod.positions()[0] - p0 - w.time() * u;
      ASSERT_LT(std::hypot(off.y(), off.z()), 1e-12) << "step " << k;
      const Vec3 v = rod.velocities()[0];
      ASSERT_LT((Vec3(0.0, v.y(), v.z()) - u).norm(), 1e-9) << "step " << k;
    }
    EXPECT_TRUE(rod.remove_node_constraint(0));
    EXPECT_FALSE(rod.remove_node_constraint(0));
    EXPECT_TRUE(rod.node_constraints().empty());
  }
}

}  // namespace
}  // namespace corde
