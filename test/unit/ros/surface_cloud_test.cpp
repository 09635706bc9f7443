// The rod's surface as points (the node's surface_cloud): the adapter's ROS-free part.
#ifdef CORDE_TEST_ROS_ADAPTER
#include "corde_sim/ros/surface_cloud.h"

#include <gtest/gtest.h>

#include <vector>

#include "corde_sim/rod/material.h"
#include "corde_sim/rod/rod_shape.h"

namespace corde_sim {
namespace {

TEST(SurfaceCloud, PointsOnTheSurfaceCountAsDocumented) {
  corde::RodSpec spec;
  spec.shape.kind = corde::RodShape::Kind::kHelix;
  spec.shape.helix_radius = 0.1;
  spec.shape.helix_turns = 1.0;
  spec.elements = 12;
  spec.section = corde::make_section(corde::material_presets().front().material, 0.01);
  const corde::Rod rod = corde::build_rod(spec);
  std::vector<float> xyz;
  append_surface_points(rod, 3, 8, &xyz);
  ASSERT_EQ(xyz.size(), 3u * 12 * 3 * 8);
  const auto& x = rod.positions();
  for (size_t i = 0; i < xyz.size(); i += 3) {
    const corde::Vec3 p(xyz[i], xyz[i + 1], xyz[i + 2]);
    const int seg = static_cast<int>(i / 3 / 24);
    const corde::Vec3 a = x[seg], d = x[seg + 1] - x[seg];
    const double s = (p - a).dot(d) / d.squaredNorm();
    EXPECT_GT(s, 0.0);
    EXPECT_LT(s, 1.0);
    EXPECT_NEAR((a + s * d - p).norm(), 0.01, 1e-7);  // float precision
  }
}

}  // namespace
}  // namespace corde_sim
#endif
