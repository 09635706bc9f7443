// Statics as a mode (statics/scene_statics.h): the shipped V1 and V2 cantilever scenes solved
// directly against the references of cantilever_test.cpp, the drives and grasps at a chosen time,
// and `initial_state: equilibrium` starting a dynamic run at rest.
#include <gtest/gtest.h>

#include <algorithm>
#include <string>

#include "corde_sim/grasp/reactions.h"
#include "corde_sim/scene/scene.h"
#include "corde_sim/scene/scene_runner.h"
#include "corde_sim/statics/scene_statics.h"
#include "validation_util.h"

namespace corde {
namespace {

std::string shipped(const std::string& name) {
  return std::string(CORDE_SIM_SOURCE_DIR) + "/config/scenes/" + name + ".yaml";
}

// Largest |force| on a free node and |torque| / l on a free segment at the current state and time
// t, over the rod's weight and loads: what must vanish at an equilibrium. `grasped`: a segment
// that a grasp holds (with its nodes), or -1.
double relative_force_residual(Rod* rod, const Vec3& g, double t, int grasped = -1) {
  rod->compute_forces(t, g);
  double worst = 0.0, scale = 0.0;
  const double l = rod->rest_lengths()[0];
  for (int i = 0; i < rod->num_nodes(); ++i) {
    scale += rod->node_masses()[i] * g.norm();
    if (!rod->node_drive(i) && i != grasped && i != grasped + 1)
      worst = std::max(worst, rod->forces()[i].norm());
  }
  for (int s = 0; s < rod->num_segments(); ++s)
    if (!rod->segment_drive(s) && s != grasped)
      worst = std::max(worst, rod->torques()[s].norm() / l);
  for (const Load& ld : rod->loads()) scale += ld.value.norm();
  return worst / scale;
}

// V1 (alpha = 0.05, 50 elements, ghost clamp): tip deflection P L^3/(3B) + P L/kappa and slope
// P L^2/(2B). The ghost clamp is within 1% at N = 20 in cantilever_test and the elastica's
// stiffening at this alpha is -2.7e-4: 2e-3 here. The scene ramps its load over 28.6 s from
// t = 0; statics at t = 0 takes it whole (a mode that ignored loads, or stepped the dynamics
// for a while, would be far off). The clamp carries the load: force P up, moment -P x_tip.
TEST(StaticsMode, V1SceneMatchesBeamTheory) {
  Scene s = load_scene(shipped("v1_cantilever_small_load"));
  const Rod& rod = s.world.rods()[0];
  const double p = -rod.loads()[0].value.z();
  const double ref_w = p / (3.0 * rod.section().bend) + p / rod.section().kappa;
  const double ref_slope = p / (2.0 * rod.section().bend);
  const SceneEquilibrium eq = solve_scene_statics(&s, 0.0);
  ASSERT_TRUE(eq.ok) << eq.problem;
  ASSERT_EQ(eq.rods.size(), 1u);
  const RodEquilibrium& e = eq.rods[0];
  const Vec3 tip = rod.positions().back();
  std::printf(
      "V1 statics mode: tip deflection %.7f m (ref %.7f), slope %.6f (ref %.6f), %d "
      "Newton iterations\n",
      -tip.z(), ref_w, val::droop_angle(rod, 49), ref_slope, e.result.iterations);
  EXPECT_NEAR(-tip.z() / ref_w, 1.0, 2e-3);
  EXPECT_NEAR(val::droop_angle(rod, 49) / ref_slope, 1.0, 2e-3);
  EXPECT_LT(e.result.relative_residual, 1e-6);
  EXPECT_EQ(e.negative_modes, 0);
  EXPECT_EQ(e.zero_modes, 0);
  EXPECT_NEAR(e.sag, -tip.z(), 1e-15);
  EXPECT_EQ(e.lowest_node, 50);
  const Wrench w = support_reaction(rod, s.supports[0]);
  EXPECT_NEAR(w.force.z(), p, 1e-6 * p);
  EXPECT_NEAR(w.moment.y(), -p * tip.x(), 1e-6 * p);
  for (const Vec3& v : rod.velocities()) EXPECT_EQ(v.norm(), 0.0);
  // At a time the dynamic run's ramp has ended (statics took the load whole at t = 0).
  EXPECT_LT(relative_force_residual(&s.world.rods()[0], s.world.gravity, 100.0), 1e-8);
}

// V2 (alpha = 2): the elastica's vertical tip deflection 0.49346 L, shortening 0.16064 L and tip
// angle 0.78175 rad, to the validation suite's aim of 0.01 L (0.01 rad) at N = 50. The example
// rod's stretch and shear move the tip by < 2e-4 L here.
TEST(StaticsMode, V2SceneMatchesElastica) {
  Scene s = load_scene(shipped("v2_cantilever_large_load"));
  const SceneEquilibrium eq = solve_scene_statics(&s, 0.0);
  ASSERT_TRUE(eq.ok) << eq.problem;
  const Rod& rod = s.world.rods()[0];
  const Vec3 tip = rod.positions().back();
  std::printf("V2 statics mode: w %.5f u %.5f angle %.5f, %d Newton iterations, %d load steps\n",
              -tip.z(), 1.0 - tip.x(), val::droop_angle(rod, 49), eq.rods[0].result.iterations,
              eq.rods[0].result.load_steps);
  EXPECT_NEAR(-tip.z(), 0.49346, 0.01);
  EXPECT_NEAR(1.0 - tip.x(), 0.16064, 0.01);
  EXPECT_NEAR(val::droop_angle(rod, 49), 0.78175, 0.01);
  EXPECT_EQ(eq.rods[0].negative_modes, 0);
  const std::string text = statics_summary(s, eq);
  for (const char* want : {"converged", "Newton iterations", "1 load step", "stable", "sag 0.49",
                           "beam/clamp start: force (", "0.15708) N"})
    EXPECT_NE(text.find(want), std::string::npos) << want << " in\n" << text;
}

// A load that starts later acts only from its start_time on: statics at t = 2 s has none of
// V1's load delayed to 5 s, at t = 5 s all of it.
TEST(StaticsMode, LoadsFromTheirStartTime) {
  for (double t : {2.0, 5.0}) {
    Scene s = load_scene(shipped("v1_cantilever_small_load"), {"rods.0.loads.0.start_time=5"});
    const SceneEquilibrium eq = solve_scene_statics(&s, t);
    ASSERT_TRUE(eq.ok) << eq.problem;
    EXPECT_EQ(s.world.time(), t);
    const double w = -s.world.rods()[0].positions().back().z();
    if (t < 5.0)
      EXPECT_LT(std::abs(w), 1e-12);
    else
      EXPECT_NEAR(w, 1.66704e-2, 5e-5);
  }
}

const char* kGrasped = R"(
name: carried
time_step: auto
duration: 0.01
rods:
  - name: cable
    elements: 8
    material: {preset: soft_cable}
    shape: {type: straight, start: [0, 0, 1], direction: [1, 0, 0], length: 0.2}
    boundary:
      - {clamp: start}
grasps:
  - {name: gripper, place: end, move_by: [-0.05, 0, 0.1], ramp_time: 2, start_time: 1}
)";

// Statics at t puts a scripted grasp where its keyframes have it then: before it moves, half
// way (the smooth ramp's midpoint is half the move) and after.
TEST(StaticsMode, GraspAtTheGivenTime) {
  const Vec3 start(0.2 - 0.0125, 0.0, 1.0);  // midpoint of the last of 8 segments of 0.025 m
  for (auto [t, fraction] : {std::pair{0.5, 0.0}, {2.0, 0.5}, {4.0, 1.0}}) {
    Scene s = parse_scene(kGrasped);
    const SceneEquilibrium eq = solve_scene_statics(&s, t);
    ASSERT_TRUE(eq.ok) << eq.problem;
    const Rod& rod = s.world.rods()[0];
    const Vec3 mid = 0.5 * (rod.positions()[7] + rod.positions()[8]);
    EXPECT_LT((mid - (start + fraction * Vec3(-0.05, 0.0, 0.1))).norm(), 1e-9) << "t = " << t;
    EXPECT_LT(relative_force_residual(&s.world.rods()[0], s.world.gravity, t), 1e-6);
  }
}

const char* kStill = "grasps=[{name: gripper, place: end}]";

// initial_state: equilibrium: the run starts at rest with the forces balanced, and stays put for
// 1000 steps (the given straight shape falls by about 1e-4 m in that time).
TEST(StaticsMode, InitialEquilibriumStartsAtRestAndStays) {
  for (const char* where : {"initial_state=equilibrium", "rods.0.initial_state=equilibrium"}) {
    Scene s = parse_scene(kGrasped, {where, kStill});
    ASSERT_EQ(s.settled.size(), 1u) << where;
    Rod& rod = s.world.rods()[0];
    for (size_t i = 0; i < rod.velocities().size(); ++i) EXPECT_EQ(rod.velocities()[i].norm(), 0.0);
    for (const Vec3& w : rod.angular_velocities()) EXPECT_EQ(w.norm(), 0.0);
    EXPECT_LT(relative_force_residual(&rod, s.world.gravity, 0.0, 7), 1e-8);
    EXPECT_EQ(rod.node_drives().size(), 1u);  // the clamp; the run holds the grasp itself
    const std::vector<Vec3> x0 = rod.positions();
    const RunResult r = run_scene(&s);
    ASSERT_TRUE(r.ok);
    double moved = 0.0;
    for (int i = 0; i < rod.num_nodes(); ++i)
      moved = std::max(moved, (rod.positions()[i] - x0[i]).norm());
    EXPECT_LT(moved, 1e-9) << where;
  }
  Scene given = parse_scene(kGrasped, {kStill});
  EXPECT_TRUE(given.settled.empty());
  const Vec3 mid0 = given.world.rods()[0].positions()[4];
  run_scene(&given);
  EXPECT_GT((given.world.rods()[0].positions()[4] - mid0).norm(), 1e-5);
}

// The rod's own key overrides the scene's; errors name the key and say why.
TEST(StaticsMode, InitialStateKeysAndErrors) {
  Scene s = parse_scene(kGrasped, {"initial_state=equilibrium", "rods.0.initial_state=given"});
  EXPECT_TRUE(s.settled.empty());
  auto error = [](const std::vector<std::string>& overrides) {
    try {
      parse_scene(kGrasped, overrides);
    } catch (const SceneError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  std::string m = error({"initial_state=rest"});
  EXPECT_NE(m.find("initial_state"), std::string::npos) << m;
  EXPECT_NE(m.find("equilibrium"), std::string::npos) << m;
  m = error({"rods.0.initial_state=equilibrium", "rods.0.initial={velocity: [1, 0, 0]}"});
  EXPECT_NE(m.find("rods[0].initial_state"), std::string::npos) << m;
  EXPECT_NE(m.find("remove its `initial` key"), std::string::npos) << m;
  m = error({"initial_state=equilibrium", "obstacles=[{type: plane, normal: [0, 0, 1]}]"});
  EXPECT_EQ(m.rfind("initial_state", 0), 0u) << m;
  EXPECT_NE(m.find("touches the scene's obstacles"), std::string::npos) << m;
  m = error({"initial_state=equilibrium",
             "rods.0.loads=[{node: 3, force: [0, 0, -1], kind: "
             "follower}]"});
  EXPECT_NE(m.find("follower load"), std::string::npos) << m;
}

}  // namespace
}  // namespace corde
