// Shipped contact scenes: config/scenes/drape_table.yaml, a power cord dropped onto a table near
// its edge, drapes over it and comes to rest without sinking into the table or the bar (both from
// the package's urdf/table_with_bar.urdf). Penetration is checked by the contact stage's report
// and by the geometry alone (overlap_util.h), which sees the cord sink with contacts off.
#include <gtest/gtest.h>

#include <algorithm>
#include <set>
#include <string>

#include "corde_sim/scene/scene.h"
#include "corde_sim/world/world.h"
#include "overlap_util.h"

namespace corde {
namespace {

TEST(ContactScenes, DrapeTableRestsDrapedWithoutPenetration) {
  Scene s = load_scene(std::string(CORDE_SIM_SOURCE_DIR) + "/config/scenes/drape_table.yaml");
  World& w = s.world;
  // The URDF's collision elements: the top, four legs and the bar.
  ASSERT_NE(w.obstacles, nullptr);
  std::set<std::string> names;
  for (int i = 0; i < w.obstacles->size(); ++i) names.insert(w.obstacles->obstacle(i).name);
  EXPECT_EQ(names,
            (std::set<std::string>{"table/top", "table/leg_front_left", "table/leg_front_right",
                                   "table/leg_back_left", "table/leg_back_right", "table/bar"}));
  const Rod& cord = w.rods()[0];
  const double radius = cord.section().radius;
  const double top = 0.75;  // the table's top (box centre 0.73, height 0.04)
  double worst = 0.0, geometric = 0.0;
  const int steps = static_cast<int>(s.duration / w.time_step);
  for (int k = 0; k < steps; ++k) {
    w.step();
    ASSERT_NE(w.contacts(), nullptr);
    worst = std::max(worst, w.contacts()->stats().max_penetration);
    if (k % 10 == 0) geometric = std::max(geometric, testing_overlap::measure_overlap(w).worst());
  }
  ASSERT_TRUE(w.finite());
  EXPECT_LT(worst, 0.01 * radius) << "deepest penetration over the run";
  EXPECT_LT(geometric, 0.01 * radius) << "deepest overlap from the geometry";

  // Draped: the start lies on the table, the end hangs below its top, past the edge (x = 0.6).
  const auto& x = cord.positions();
  const int n = cord.num_nodes();
  EXPECT_NEAR(x[0].z(), top + radius, 0.1 * radius);
  EXPECT_LT(x[0].x(), 0.6);
  EXPECT_LT(x[n - 1].z(), top - 0.2);
  int on_table = 0, below = 0;
  for (const Vec3& p : x) {
    if (p.x() < 0.6 && std::abs(p.z() - (top + radius)) < 0.1 * radius) ++on_table;
    if (p.z() < top - radius) ++below;
  }
  // The cord arches over the bar and before the edge (its bending length is 15 cm): about 14 of
  // its 61 nodes rest flat on the top, 16 hang below it.
  EXPECT_GE(on_table, 8);
  EXPECT_GT(below, n / 5);
  // At rest: no node moves faster than 5 cm/s at the end.
  double vmax = 0.0;
  for (const Vec3& v : cord.velocities()) vmax = std::max(vmax, v.norm());
  EXPECT_LT(vmax, 0.05);
}

// The same cord with its obstacle contacts off falls through the table top within 0.15 s (3 cm
// in 0.08 s): the geometric measure the test above relies on sees it.
TEST(ContactScenes, DrapeTableWithoutObstacleContactsSinks) {
  Scene s = load_scene(std::string(CORDE_SIM_SOURCE_DIR) + "/config/scenes/drape_table.yaml",
                       {"rods.cord.contact.obstacles=false"});
  const double radius = s.world.rods()[0].section().radius;
  const int steps = static_cast<int>(0.15 / s.world.time_step);
  double geometric = 0.0;
  for (int k = 0; k < steps; ++k) {
    s.world.step();
    if (k % 10 == 0)
      geometric = std::max(geometric, testing_overlap::measure_overlap(s.world).obstacle);
  }
  EXPECT_GT(geometric, 0.5 * radius);
}

}  // namespace
}  // namespace corde
