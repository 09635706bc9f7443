// A limp rope dropped onto a floor at the 2 ms frame: where it lands its chords are compressed and
// the exact Hessian of the step is indefinite at every Newton iteration. The step must still
// converge within its iterations (else the guard halves the step at every landing).
#include <gtest/gtest.h>

#include <string>

#include "corde_sim/scene/scene.h"
#include "corde_sim/world/world.h"
#include "overlap_util.h"

namespace corde {
namespace {

// rope_pile.yaml's limp rope (100 elements, B = 2.5e-5 N m^2, E_s 20 MPa), standing on its end
// 1 cm above the floor and let go: its bottom lands at about 45 ms and it folds into a pile.
const char* kDroppedRope = R"(
gravity: [0, 0, -9.81]
time_step: 2.0e-3
integrator: implicit_euler
duration: 0.2
contact: {friction: 0.4}
obstacles:
  - {name: floor, type: plane, normal: [0, 0, 1], friction: 0.5}
rods:
  - name: rope
    elements: 100
    radius: 0.005
    material: {preset: paper_rope, E: 5.0e4, G: 5.0e4}
    shape: {type: straight, start: [0, 0, 0.015], direction: [0, 0, 1], length: 1.5}
    initial:
      perturbation: {position: 1.0e-4, seed: 1}
    contact: {self: true}
)";

TEST(ImplicitLanding, LimpRopeDroppedAtTwoMillisecondsConvergesEveryStep) {
  Scene s = parse_scene(kDroppedRope);
  World& w = s.world;
  int unconverged = 0, most = 0;
  for (int k = 0; k < 100; ++k) {
    w.step();
    ASSERT_TRUE(w.finite()) << "step " << k;
    unconverged += w.implicit_stats().unconverged;
    most = std::max(most, w.implicit_stats().iterations);
  }
  EXPECT_EQ(unconverged, 0) << "steps whose Newton solve did not converge";
  EXPECT_LT(most, w.implicit.max_iterations);
}

// The same landing, its overlaps from the geometry after every step: into the floor below 1 % of
// r (a self contact's push-out pressed a node 2 % of r into it), through itself below 2 % of r
// (redetection within a step had undone the passes' relinearisation: 0.09 r).
TEST(ImplicitLanding, LandingKeepsTheFloorAndBoundsSelfOverlapEveryStep) {
  Scene s = parse_scene(kDroppedRope);
  World& w = s.world;
  const double r = w.rods()[0].section().radius;
  const auto res = testing_overlap::run_checked_every_step(&w, 2.0);
  ASSERT_TRUE(w.finite());
  EXPECT_LT(res.deepest.obstacle, 0.01 * r) << "into the floor, worst at t = " << res.worst_time;
  EXPECT_LT(res.deepest.self, 0.02 * r) << "through itself, worst at t = " << res.worst_time;
}

// The target: below 1 % of r through itself too. Not met yet (docs/model.md, "What the implicit
// contact solve guarantees"): 1.2 % of r at one of 1000 steps, where 8 passes do not settle the
// contacts of a strand sliding over another at 0.4 m/s.
TEST(ImplicitLanding, DISABLED_LandingKeepsSelfOverlapBelowOnePercentEveryStep) {
  Scene s = parse_scene(kDroppedRope);
  World& w = s.world;
  const double r = w.rods()[0].section().radius;
  const auto res = testing_overlap::run_checked_every_step(&w, 2.0);
  ASSERT_TRUE(w.finite());
  EXPECT_LT(res.deepest.self, 0.01 * r) << "through itself, worst at t = " << res.worst_time;
}

}  // namespace
}  // namespace corde
