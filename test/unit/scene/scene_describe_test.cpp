// The scene loader's first pass (scene_passes.h) reads and checks every entry before anything is
// built: a bad value in a rod's initial state or boundary, a grasp or an obstacle is reported
// even when an earlier entry holds an error only the built rod shows (an index out of range).
#include <gtest/gtest.h>

#include <string>

#include "corde_sim/scene/obstacle_checks.h"
#include "corde_sim/scene/scene.h"
#include "scene_test_util.h"

namespace corde {
namespace {

using test::scene_error_of;

// rods[0] has a load on node 99 of a rod with 5 nodes: an error found when its index is resolved
// against the built rod (pass b). `rest` adds a second rod and top-level entries.
std::string scene_with(const std::string& second_rod, const std::string& rest) {
  return "duration: 0.01\n"
         "time_step: 1.0e-5\n"
         "rods:\n"
         "  - name: a\n"
         "    elements: 4\n"
         "    material: soft_cable\n"
         "    shape: {type: straight, start: [0, 0, 1], direction: [1, 0, 0], length: 0.2}\n"
         "    loads: [{node: 99, force: [0, 0, -1]}]\n"
         "  - name: b\n"
         "    elements: 4\n"
         "    material: soft_cable\n"
         "    shape: {type: straight, start: [0, 1, 1], direction: [1, 0, 0], length: 0.2}\n" +
         second_rod + rest;
}

TEST(SceneDescribe, TheBuildErrorAloneIsReported) {
  EXPECT_EQ(scene_error_of(scene_with("", "")),
            "rods[0].loads[0].node: node index '99' out of range (0..4, start or end) (line 8)");
}

// Before the describe pass read boundary entries, rods[0]'s index error (pass b) came first.
TEST(SceneDescribe, BadBoundaryEntryReportedBeforeAnythingIsBuilt) {
  EXPECT_EQ(scene_error_of(scene_with("    boundary: [{clamp: start, kind: glued}]\n", "")),
            "rods[1].boundary[0].kind: expected one of natural, ghost, got 'glued' (line 13)");
}

TEST(SceneDescribe, BadInitialEntryReportedBeforeAnythingIsBuilt) {
  EXPECT_EQ(scene_error_of(scene_with("    initial: {velocity: [0, 0, 1.0e9]}\n", "")),
            "rods[1].initial.velocity: each component must be within +-10000 m/s, got 1e+09 "
            "(line 13)");
}

TEST(SceneDescribe, BadGraspEntryReportedBeforeAnythingIsBuilt) {
  EXPECT_EQ(scene_error_of(scene_with("", "grasps: [{name: g, rod: b, grasp_time: -1}]\n")),
            "grasps[0].grasp_time: must be >= 0, got -1 (line 13)");
  EXPECT_EQ(scene_error_of(scene_with("", "grasps: [{name: g, rod: c}]\n")),
            "grasps[0].rod: no rod named 'c' (rods: 'a, b') (line 13)");
}

TEST(SceneDescribe, BadObstacleEntryReportedBeforeAnythingIsBuilt) {
  EXPECT_EQ(scene_error_of(scene_with("", "obstacles: [{type: box, size: [1, 0, 1]}]\n")),
            "obstacles[0].size: every side must be > 0 (line 13)");
}

// Keyframes given as absolute poses are checked when read; only their placement waits for the
// built rod.
TEST(SceneDescribe, BadKeyframeReportedBeforeAnythingIsBuilt) {
  EXPECT_EQ(
      scene_error_of(scene_with(
          "    boundary: [{node: end, keyframes: [{time: 0.1, position: [0, 0, 1.0e9]}]}]\n", "")),
      "rods[1].boundary[0].keyframes[0].position: each component must be within +-10000 m, got "
      "1e+09 "
      "(line 13)");
}

// elements: auto probes the described scene (built at 16 and 8 elements): a node number on the
// auto rod is checked against each probe's rod and named at its line in the file. (Probing copies
// of the YAML tree named line 1.)
TEST(SceneDescribe, AutoRodInitialNodeCheckedAgainstTheProbeNamingItsLine) {
  EXPECT_EQ(scene_error_of("duration: 0.01\n"
                           "rods:\n"
                           "  - elements: auto\n"
                           "    material: soft_cable\n"
                           "    shape: {type: straight, start: [0, 0, 1], direction: [1, 0, 0], "
                           "length: 0.3}\n"
                           "    initial: {node_velocities: [{node: 20, velocity: [0, 0, 1]}]}\n"),
            "rods[0].initial.node_velocities[0].node: must be <= 16, got '20' (line 6)");
}

TEST(ObstacleChecks, ValuesAScenePrimitiveMayHave) {
  Obstacle o;
  o.name = "box";
  o.shape.kind = ObstacleShape::Kind::kBox;
  o.shape.size = Vec3(1, 2, 3);
  EXPECT_EQ(obstacle_value_error(o), "");
  EXPECT_EQ(obstacle_placement_error(o), "");
  o.shape.size.y() = 0.0;
  EXPECT_EQ(obstacle_value_error(o), "box side 1 must be > 0 m, got 0");
  o.shape.size.y() = 2.0;
  o.friction = -0.1;
  EXPECT_EQ(obstacle_value_error(o), "friction must be in [0, 1e+06], got -0.1");
  o.friction = 0.5;
  o.shape.kind = ObstacleShape::Kind::kCapsule;
  o.shape.size = Vec3(0.1, 2e4, 0);
  EXPECT_EQ(obstacle_value_error(o), "length must be <= 10000 m, got 20000");
  o.shape.size = Vec3(0.1, 1, 0);
  o.pose.translation().x() = 2e5;
  EXPECT_EQ(obstacle_placement_error(o),
            "obstacle 'box' has a position or size of 200000 m, beyond 100000 m");
  o.pose.linear() *= 2.0;
  EXPECT_EQ(obstacle_value_error(o), "the pose's orientation is not a rotation");
}

}  // namespace
}  // namespace corde
