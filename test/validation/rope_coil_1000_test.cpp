// A long rope on a floor with self contact: config/scenes/rope_coil_1000.yaml (1000 elements, a
// flat spiral with its end across the turns, dropped 1 cm, backward Euler at 2 ms). A short run
// through the landing, its penetration measured from the node positions (overlap_util.h), not
// from the contact stage's report; the same scene without self contact shows the end sinking
// through the turns, which the measure catches.
#include <gtest/gtest.h>

#include <string>

#include "corde_sim/scene/scene.h"
#include "corde_sim/world/world.h"
#include "overlap_util.h"

namespace corde {
namespace {

using testing_overlap::run_watched;

const std::string kScene = std::string(CORDE_SIM_SOURCE_DIR) + "/config/scenes/rope_coil_1000.yaml";

// 0.2 s: the drop (about 45 ms), the landing and the end settling onto the turns.
TEST(RopeCoil1000, LandsAndRestsWithoutPenetration) {
  Scene s = load_scene(kScene);
  World& w = s.world;
  const Rod& rope = w.rods()[0];
  ASSERT_EQ(rope.num_segments(), 1000);
  const double r = rope.section().radius;
  const auto res = run_watched(&w, 0.2, 5);
  ASSERT_TRUE(w.finite());
  EXPECT_EQ(w.implicit_stats().unconverged, 0);
  EXPECT_LT(res.geometric.obstacle, 0.01 * r) << "into the floor";
  EXPECT_LT(res.geometric.self, 0.01 * r) << "through itself";
  // The spiral lies on the floor and the end rests on the turns, one strand up.
  int on_floor = 0, above = 0;
  for (const Vec3& p : rope.positions()) {
    on_floor += p.z() < 1.05 * r;
    above += p.z() > 2.5 * r;
  }
  EXPECT_GT(on_floor, 800);
  EXPECT_GT(above, 5);
  int self_active = 0;
  for (const Contact& k : w.contacts()->contacts())
    if (k.rod_b == k.rod_a && k.pn > 0.0) ++self_active;
  EXPECT_GE(self_active, 3) << "the end carried by the turns below";
}

TEST(RopeCoil1000, WithoutSelfContactTheEndSinksThroughTheTurns) {
  Scene s = load_scene(kScene, {"rods.rope.contact.self=false"});
  const double r = s.world.rods()[0].section().radius;
  const auto res = run_watched(&s.world, 0.2, 5);
  EXPECT_LT(res.geometric.obstacle, 0.01 * r) << "the floor still holds";
  EXPECT_GT(res.geometric.self, 0.5 * r);
}

}  // namespace
}  // namespace corde
