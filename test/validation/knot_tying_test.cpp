// Tying a knot with grasps: config/scenes/tie_overhand_knot.yaml starts with a straight rope; the
// grasp `right` makes a bight, crosses over the standing part, dives under it and comes up
// through the loop (keyframes from scripts/tie_knot_path.py), then both ends are pulled apart at
// 6 mm/s. The result must be a trefoil (knot determinant 3 in every projection), reached without
// any strand passing through another and without the stability guard stepping in; the control
// path, which comes up beside the loop instead of through it, must leave the rope unknotted.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "corde_sim/grasp/grasp.h"
#include "corde_sim/grasp/reactions.h"
#include "corde_sim/scene/scene.h"
#include "corde_sim/scene/scene_runner.h"
#include "knot_util.h"

namespace corde {
namespace {

const std::string kScene =
    std::string(CORDE_SIM_SOURCE_DIR) + "/config/scenes/tie_overhand_knot.yaml";
// The tying ends at 34.65 s; both ends are held still until 36.65 s, then pulled for 40 s.
constexpr double kTied = 36.65;
const Vec3 kViews[] = {Vec3(0.1234, 0.3456, 1.0), Vec3(1.0, 0.2, 0.3), Vec3(0.3, 1.0, 0.1)};

struct TieRun {
  std::vector<long> tied, end;  // knot determinants in kViews when tied and at the end
  double closest = INFINITY;    // smallest distance of non-neighbouring segments' axes (m)
  double loop_tied = 0.0, loop_end = 0.0;      // largest distance of a node from the ends' line (m)
  double force_early = 0.0, force_late = 0.0;  // mean pull (N), first and last 5 s of the pull
  double radius = 0.0;
};

double off_line_max(const Rod& rod) {
  const auto& x = rod.positions();
  const Vec3 a = (x.back() - x.front()).normalized();
  double d = 0.0;
  for (const Vec3& p : x) {
    const Vec3 r = p - x.front();
    d = std::max(d, (r - a * a.dot(r)).norm());
  }
  return d;
}

std::vector<long> determinants(const Rod& rod) {
  std::vector<long> d;
  for (const Vec3& v : kViews) d.push_back(knot_determinant(rod.positions(), v));
  return d;
}

// Runs the scene (with `overrides`) to `end` s, holding and moving the grasps as corde_run does.
TieRun run_tie(const std::vector<std::string>& overrides, double end) {
  Scene s = load_scene(kScene, overrides);
  World& w = s.world;
  Rod& rod = w.rods()[0];
  struct Held {
    Grasp grasp;
    Eigen::Isometry3d start;
    const Motion* motion;
  };
  std::vector<Held> held;
  for (const GraspSpec& spec : s.grasps) {
    const Eigen::Isometry3d pose = segment_pose(rod, grasp_segment(rod, spec));
    held.push_back({make_grasp(rod, spec, pose), pose, spec.motion.get()});
  }
  const Support* right = nullptr;
  for (const Support& sp : s.supports)
    if (sp.name == "right") right = &sp;
  EXPECT_NE(right, nullptr);

  TieRun run;
  run.radius = rod.section().radius;
  const double h = w.time_step;
  double early = 0.0, late = 0.0;
  int n_early = 0, n_late = 0;
  for (long k = 1; w.time() < end - 0.5 * h; ++k) {
    for (const Held& g : held) hold(rod, g.grasp, g.motion->pose_at(w.time() + h, g.start));
    w.step();
    // Sampled every 50 steps (8.6 ms): a strand moves at most a few mm/s relative to another.
    if (k % 50 == 0) run.closest = std::min(run.closest, closest_non_neighbours(rod, 2));
    if (w.time() <= kTied && w.time() + h > kTied) {
      run.tied = determinants(rod);
      run.loop_tied = off_line_max(rod);
    }
    const double t = w.time();
    if (right && t > kTied && t <= kTied + 5.0) {
      early += support_reaction(rod, *right).force.x();
      ++n_early;
    }
    if (right && t > end - 5.0) {
      late += support_reaction(rod, *right).force.x();
      ++n_late;
    }
  }
  EXPECT_TRUE(w.finite());
  run.end = determinants(rod);
  run.loop_end = off_line_max(rod);
  run.force_early = early / std::max(1, n_early);
  run.force_late = late / std::max(1, n_late);
  return run;
}

// The scene as shipped: tied, then pulled tight; a trefoil from the tying on, no pass-through.
TEST(TieOverhandKnot, GraspsTieATrefoilAndPullItTight) {
  Scene probe = load_scene(kScene);
  const TieRun run = run_tie({}, probe.duration);
  std::printf("closest %.4f r; loop %.4f -> %.4f m; pull %.3g -> %.3g N\n",
              run.closest / run.radius, run.loop_tied, run.loop_end, run.force_early,
              run.force_late);
  for (long d : run.tied) EXPECT_EQ(d, 3) << "when tied";
  for (long d : run.end) EXPECT_EQ(d, 3) << "at the end";
  EXPECT_GE(run.closest, 2.0 * run.radius - 0.01 * run.radius);
  // Pulled tight: the loop shrinks and the pull force grows.
  EXPECT_LT(run.loop_end, 0.7 * run.loop_tied);
  EXPECT_GT(run.force_late, 2.0 * run.force_early);
  EXPECT_GT(run.force_early, 0.0);
}

// The control: the same moves, but the end comes up beside the loop, not through it.
TEST(TieOverhandKnot, ControlPathLeavesTheRopeUnknotted) {
  const TieRun run =
      run_tie({"grasps.right.keyframes={file: tie_overhand_knot_control.csv}"}, 42.0);
  for (long d : run.end) EXPECT_EQ(d, 1);
  EXPECT_GE(run.closest, 2.0 * run.radius - 0.01 * run.radius);
}

// corde_run's loop with the stability guard: the tying runs without a guard event.
TEST(TieOverhandKnot, TyingNeedsNoGuardEvent) {
  Scene s = load_scene(kScene);
  RunOptions options;
  options.duration = kTied;
  const RunResult r = run_scene(&s, options);
  EXPECT_TRUE(r.ok) << r.problem;
  EXPECT_TRUE(r.guard_events.empty()) << r.guard_events.size() << " events";
  for (const Vec3& v : kViews) EXPECT_EQ(knot_determinant(s.world.rods()[0].positions(), v), 3);
}

}  // namespace
}  // namespace corde
