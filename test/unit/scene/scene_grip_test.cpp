// The grasp key `grip` (a friction grasp): read into GraspSpec::grip, bad values rejected naming
// the key and the value, and a scene with it run by corde_run's loop slides and lets go.
#include <gtest/gtest.h>

#include <string>

#include "corde_sim/scene/scene.h"
#include "corde_sim/scene/scene_runner.h"

namespace corde {
namespace {

// A 0.6 m cable hanging from a gripper 0.15 m below its top; GRIP is replaced by each test.
const char* kScene = R"(
name: grip
gravity: [0, 0, -9.81]
integrator: implicit_euler
time_step: 1.0e-3
duration: 0.4
rods:
  - name: cable
    elements: 24
    radius: 0.003
    material: {preset: soft_cable}
    shape: {type: straight, start: [0, 0, 1.0], direction: [0, 0, -1], length: 0.6}
    reference_d1: [1, 0, 0]
grasps:
  - {name: gripper, place: arc_length, value: 0.15, GRIP}
)";

std::string with_grip(const std::string& grip) {
  std::string s = kScene;
  s.replace(s.find("GRIP"), 4, grip);
  return s;
}

void expect_error(const std::string& grip, const std::string& path, const std::string& fragment) {
  try {
    parse_scene(with_grip(grip));
    ADD_FAILURE() << "no error for " << grip;
  } catch (const SceneError& e) {
    const std::string msg = e.what();
    EXPECT_EQ(msg.rfind(path + ":", 0), 0u) << "message: " << msg;
    EXPECT_NE(msg.find(fragment), std::string::npos) << "message: " << msg;
  }
}

TEST(SceneGrip, ReadsForceAndMu) {
  const Scene s = parse_scene(with_grip("grip: {force: 0.333, mu: 0.5}"));
  ASSERT_EQ(s.grasps.size(), 1u);
  EXPECT_TRUE(s.grasps[0].grip.friction);
  EXPECT_EQ(s.grasps[0].grip.force, 0.333);
  EXPECT_EQ(s.grasps[0].grip.mu, 0.5);
  const Scene rigid = parse_scene(with_grip("hold_orientation: true"));
  EXPECT_FALSE(rigid.grasps[0].grip.friction);
}

TEST(SceneGrip, BadValuesNameTheKey) {
  expect_error("grip: {force: -1, mu: 0.5}", "grasps[0].grip.force", "must be >= 0, got -1");
  expect_error("grip: {force: 1, mu: -0.2}", "grasps[0].grip.mu", "must be >= 0, got -0.2");
  expect_error("grip: {force: 1}", "grasps[0].grip.mu", "missing");
  expect_error("grip: {mu: 1}", "grasps[0].grip.force", "missing");
  expect_error("grip: {force: 1, mu: 0.5, radius: 2}", "grasps[0].grip.radius", "unknown key");
  expect_error("grip: {force: .nan, mu: 0.5}", "grasps[0].grip.force", "finite");
  expect_error("grip: 3", "grasps[0].grip", "map");
}

// corde_run's loop: the cable slides out of the grip (mu N half its weight) and is let go.
TEST(SceneGrip, RunSlidesOutAndLetsGo) {
  Scene s = parse_scene(with_grip("grip: {force: 0.333, mu: 0.5}"));
  const Vec3 start = s.world.rods()[0].center_of_mass();
  const RunResult r = run_scene(&s, RunOptions());
  ASSERT_TRUE(r.ok) << r.problem;
  // Let go after about 0.25 s, then falling: at 0.4 s it is well below where a held cable stays.
  const double drop = start.z() - s.world.rods()[0].center_of_mass().z();
  EXPECT_GT(drop, 0.2);
  // Held rigidly instead (no grip), it stays within its stretch.
  Scene held = parse_scene(with_grip("hold_orientation: true"));
  const Vec3 start_held = held.world.rods()[0].center_of_mass();
  ASSERT_TRUE(run_scene(&held, RunOptions()).ok);
  EXPECT_LT(start_held.z() - held.world.rods()[0].center_of_mass().z(), 1e-3);
}

}  // namespace
}  // namespace corde
