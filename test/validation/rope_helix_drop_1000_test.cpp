// Many contacts at once on one long rope: config/scenes/rope_helix_drop_1000.yaml (1000 elements
// set as a helix of 6.4 turns standing on a floor, backward Euler at 2 ms) collapses turn on turn
// into a stack with about a thousand contacts carrying load at once. A short run through the
// collapse, its penetration measured from the node positions (overlap_util.h), not from the
// contact stage's report; and corde_run's loop with the stability guard over the same time.
#include <gtest/gtest.h>

#include <algorithm>
#include <string>

#include "corde_sim/scene/scene.h"
#include "corde_sim/scene/scene_runner.h"
#include "corde_sim/world/world.h"
#include "overlap_util.h"

namespace corde {
namespace {

using testing_overlap::run_watched;

const std::string kScene =
    std::string(CORDE_SIM_SOURCE_DIR) + "/config/scenes/rope_helix_drop_1000.yaml";

// 0.3 s: the column collapses (the top turn lands at about 0.2 s) and the stack settles.
constexpr double kCollapse = 0.3;

TEST(RopeHelixDrop1000, CollapsesOnManyContactsWithoutPenetration) {
  Scene s = load_scene(kScene);
  World& w = s.world;
  const Rod& rope = w.rods()[0];
  ASSERT_EQ(rope.num_segments(), 1000);
  const double r = rope.section().radius;
  const auto res = run_watched(&w, kCollapse, 5);
  ASSERT_TRUE(w.finite());
  EXPECT_EQ(w.implicit_stats().unconverged, 0);
  EXPECT_LT(res.geometric.obstacle, 0.01 * r) << "into the floor";
  EXPECT_LT(res.geometric.self, 0.01 * r) << "through itself";
  // The turns lie stacked: the top one at least five strands up, and about a thousand contacts
  // carry load at once.
  double top = 0.0;
  for (const Vec3& p : rope.positions()) top = std::max(top, p.z());
  EXPECT_GT(top, 5.0 * 2.0 * r);
  int self_active = 0, active = 0;
  for (const Contact& k : w.contacts()->contacts()) {
    if (!(k.pn > 0.0)) continue;
    ++active;
    self_active += k.rod_b == k.rod_a;
  }
  EXPECT_GT(active, 1000);
  EXPECT_GT(self_active, 500);
}

TEST(RopeHelixDrop1000, CollapseNeedsNoGuardEvent) {
  Scene s = load_scene(kScene);
  RunOptions options;
  options.duration = kCollapse;
  const RunResult res = run_scene(&s, options);
  EXPECT_TRUE(res.ok) << res.problem;
  EXPECT_TRUE(res.guarded);
  EXPECT_TRUE(res.guard_events.empty()) << res.guard_events.size() << " events";
}

}  // namespace
}  // namespace corde
