// Scene keys for keyframed drives, constraints, follower loads, initial conditions, keyframe
// files (relative to the scene's folder) and corde_run's reaction and energy output.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

#include "corde_sim/scene/scene.h"
#include "corde_sim/scene/scene_runner.h"

namespace corde {
namespace {

constexpr double kPi = 3.14159265358979323846;

std::string scene(const std::string& boundary, const std::string& rod_extra = "",
                  const std::string& grasps = "") {
  return "time_step: 1.0e-5\nduration: 0.02\nrods:\n  - name: cable\n    elements: 10\n"
         "    radius: 0.003\n    material: {E: 3.0e7, G: 1.0e7, E_s: 5.0e8, rho: 2000}\n"
         "    shape: {type: straight, start: [0, 0, 1], direction: [1, 0, 0], length: 0.5}\n" +
         rod_extra + "    boundary:\n" + boundary + grasps;
}

void expect_error(const std::string& yaml, const std::string& path, const std::string& fragment,
                  const std::string& source = "<string>") {
  try {
    parse_scene(yaml, {}, source);
    ADD_FAILURE() << "no error; expected '" << path << ": ..." << fragment << "'";
  } catch (const SceneError& e) {
    const std::string msg = e.what();
    EXPECT_EQ(msg.rfind(path + ":", 0), 0u) << "message: " << msg;
    EXPECT_NE(msg.find(fragment), std::string::npos) << "message: " << msg;
  }
}

TEST(SceneMotion, DrivesConstraintsAndSupportsFromKeys) {
  const Scene s = parse_scene(scene(
      "      - {clamp: start, move_by: [0, 0, -0.1], turns: 3, ramp_time: 0.5, start_time: 0.1}\n"
      "      - {clamp: end, kind: natural, twist: free, slide: true}\n"
      "      - {node: 5, plane: [0, 0, 1]}\n"
      "      - {segment: 3, keyframes: [{time: 0.2, turns: 1}, {time: 0.4, orientation: [0, 0, 0, "
      "1]}], interpolation: linear}\n"
      "      - {segment: 7, free_axis: tangent}\n"
      "    loads:\n      - {node: end, force: [1, 0, 0], kind: follower}\n",
      "",
      "grasps:\n  - {name: hand, place: node, value: 8, move_by: [0, 0, 0.1], ramp_time: 1}\n"));
  const Rod& rod = s.world.rods()[0];
  const NodeDrive* start = rod.node_drive(0);
  ASSERT_TRUE(start && start->kind == NodeDrive::Kind::kMotion && start->motion);
  EXPECT_TRUE(rod.ghost_start().active && rod.ghost_start().motion == start->motion);
  EXPECT_NEAR(start->motion->at(1.0).displacement.z(), -0.1, 1e-15);
  EXPECT_NEAR(start->motion->keyframes().back().angle, 6 * kPi, 1e-12);
  EXPECT_EQ(rod.node_drive(10), nullptr);  // the sliding end is a constraint, not a drive
  ASSERT_EQ(rod.node_constraints().size(), 2u);
  EXPECT_LT((rod.node_constraints()[0].direction - Vec3::UnitX()).norm(), 1e-15);
  ASSERT_EQ(rod.segment_constraints().size(), 2u);
  EXPECT_EQ(rod.segment_constraints()[0].segment, 9);
  EXPECT_EQ(rod.segment_drive(3)->kind, SegmentDrive::Kind::kMotion);
  EXPECT_EQ(rod.segment_drive(3)->motion->interpolation(), Motion::Interpolation::kLinear);
  EXPECT_TRUE(rod.loads()[0].follower);
  ASSERT_TRUE(s.grasps[0].motion);
  ASSERT_EQ(s.supports.size(), 6u);
  EXPECT_EQ(s.supports[0].name, "cable/clamp start");
  EXPECT_EQ(s.supports[0].ghost, 0);
  EXPECT_EQ(s.supports[2].name, "cable/boundary[2]");
  EXPECT_EQ(s.supports[5].name, "hand");
  EXPECT_EQ(s.supports[5].midpoint_of, 8);
}

TEST(SceneMotion, AbsoluteKeyframesAreRelativeToTheStart) {
  const Scene s =
      parse_scene(scene("      - {node: 0, keyframes: [{time: 0.1, position: [0.1, 0, "
                        "1.2]}, {time: 0.3, displacement: [0, 0, 0]}]}\n"));
  const Motion& m = *s.world.rods()[0].node_drive(0)->motion;
  EXPECT_LT((m.at(0.1).displacement - Vec3(0.1, 0.0, 0.2)).norm(), 1e-15);
  EXPECT_LT(m.at(0.3).displacement.norm(), 1e-15);
}

TEST(SceneMotion, MalformedKeysNameTheirPath) {
  const std::string b = "rods[0].boundary[0]";
  expect_error(scene("      - {node: 0, keyframes: [{time: 0.2}, {time: 0.1}]}\n"),
               b + ".keyframes[1]", "times must increase");
  expect_error(scene("      - {node: 0, keyframes: [{time: 0.2, turns: 1}]}\n"),
               b + ".keyframes[0].turns", "unknown key");
  expect_error(scene("      - {node: 0, keyframes: [{tim: 0.2}]}\n"), b + ".keyframes[0].time",
               "missing");
  expect_error(scene("      - {node: 0, keyframes: [{time: 0.2, position: [0, 0, 1], "
                     "displacement: [0, 0, 0]}]}\n"),
               b + ".keyframes[0]", "either position or displacement");
  expect_error(scene("      - {node: 0, keyframes: []}\n"), b + ".keyframes", "non-empty");
  expect_error(scene("      - {node: 0, move_by: [0, 0, 1]}\n"), b + ".ramp_time", "missing");
  expect_error(scene("      - {node: 0, move_by: [0, 0, 1], ramp_time: 0}\n"), b + ".ramp_time",
               "> 0");
  expect_error(scene("      - {node: 0, turns: 2, ramp_time: 1}\n"), b + ".turns",
               "cannot be turned");
  expect_error(scene("      - {node: 0, fix: true, move_by: [0, 0, 1], ramp_time: 1}\n"), b,
               "only one of");
  expect_error(scene("      - {node: 0, line: [0, 0, 0]}\n"), b + ".line", "zero");
  expect_error(scene("      - {segment: 0, move_by: [0, 0, 1], ramp_time: 1}\n"), b + ".move_by",
               "cannot be moved");
  expect_error(scene("      - {segment: 0, keyframes: [{time: 1, orientation: [0, 0, 0, 2]}]}\n"),
               b + ".keyframes[0].orientation", "unit quaternion");
  expect_error(scene("      - {segment: 0, free_axis: sideways}\n"), b + ".free_axis", "");
  expect_error(scene("      - {clamp: end, twist: free}\n"), b, "kind: natural");
  expect_error(scene("      - {clamp: end, slide: true, move_by: [1, 0, 0], ramp_time: 1}\n"),
               b + ".slide", "cannot also be moved");
  expect_error(scene("      - {clamp: end, interpolation: cubic, turns: 1, ramp_time: 1}\n"),
               b + ".interpolation", "smooth");
  expect_error(scene("      - {clamp: end, keyframes: [{time: 0, turns: 1}]}\n"),
               b + ".keyframes[0]", "start pose");
  expect_error(scene("      - {clamp: end, keyframes: {file: missing.csv}}\n"), b + ".keyframes",
               "cannot open");
  expect_error(scene("      - {node: 0, fix: true}\n    loads:\n      - {node: 3, force: [1, 0, "
                     "0], kind: sideways}\n"),
               "rods[0].loads[0].kind", "follower");
  expect_error(scene("      - {node: 0, fix: true}\n", "    initial: {spin: [0, 0, 1]}\n"),
               "rods[0].initial.spin", "unknown key");
  expect_error(
      scene("      - {node: 0, fix: true}\n", "    initial: {perturbation: {position: -1}}\n"),
      "rods[0].initial.perturbation.position", ">= 0");
  expect_error(scene("      - {node: 0, fix: true}\n",
                     "    initial: {node_velocities: [{node: 11, velocity: [0, 0, 1]}]}\n"),
               "rods[0].initial.node_velocities[0].node", "10");
  expect_error(scene("      - {node: 0, fix: true}\n", "",
                     "grasps:\n  - {name: g, keyframes: [{time: 1, position: [0, 0]}]}\n"),
               "grasps[0].keyframes[0].position", "");
}

// Initial velocities: a rigid motion about the centre of mass, per-node and per-segment values,
// and a perturbation that the seed reproduces.
TEST(SceneMotion, InitialConditions) {
  const Scene s = parse_scene(scene("      []\n",
                                    "    initial: {velocity: [0.1, 0, 0], angular_velocity: [0, "
                                    "0, 2], node_velocities: [{node: 3, velocity: [0, 1, 0]}], "
                                    "segment_angular_velocities: [{segment: 2, angular_velocity: "
                                    "[1, 0, 0]}]}\n"));
  const Rod& rod = s.world.rods()[0];
  const Vec3 c = rod.center_of_mass();
  for (int i = 0; i < rod.num_nodes(); ++i) {
    const Vec3 want = i == 3 ? Vec3(0, 1, 0)
                             : Vec3(Vec3(0.1, 0, 0) + Vec3(0, 0, 2).cross(rod.positions()[i] - c));
    EXPECT_LT((rod.velocities()[i] - want).norm(), 1e-14) << i;
  }
  EXPECT_LT((rod.orientations()[2] * rod.angular_velocities()[2] - Vec3(1, 0, 0)).norm(), 1e-14);
  EXPECT_LT((rod.orientations()[5] * rod.angular_velocities()[5] - Vec3(0, 0, 2)).norm(), 1e-14);

  auto perturbed = [&](int seed) {
    return parse_scene(scene("      []\n",
                             "    initial: {perturbation: {position: 1.0e-3, "
                             "velocity: 0.01, seed: " +
                                 std::to_string(seed) + "}}\n"))
        .world.rods()[0];
  };
  const Rod a = perturbed(7), b = perturbed(7), other = perturbed(8);
  const Rod plain = parse_scene(scene("      []\n")).world.rods()[0];
  double largest = 0.0, differs = 0.0;
  for (int i = 0; i < a.num_nodes(); ++i) {
    EXPECT_EQ(a.positions()[i], b.positions()[i]);
    EXPECT_EQ(a.velocities()[i], b.velocities()[i]);
    const Vec3 d = a.positions()[i] - plain.positions()[i];
    largest = std::max(largest, d.cwiseAbs().maxCoeff());
    EXPECT_LE(a.velocities()[i].cwiseAbs().maxCoeff(), 0.01);
    differs = std::max(differs, (a.positions()[i] - other.positions()[i]).norm());
  }
  EXPECT_LE(largest, 1e-3);
  EXPECT_GT(largest, 5e-4);  // 33 uniform samples: the largest is near the bound
  EXPECT_GT(differs, 1e-4);
}

// A keyframe file is read relative to the scene file's folder, wherever the run starts.
TEST(SceneMotion, KeyframeFileRelativeToTheScene) {
  char dir_template[] = "/tmp/corde_scene_motion_XXXXXX";
  const std::string dir = mkdtemp(dir_template);
  std::ofstream(dir + "/path.csv") << "# a hand's path\ntime,dx,dy,dz,turns\n0.01,0,0,0.01,0.5\n"
                                      "0.02,0.01,0,0.01,1\n";
  std::ofstream(dir + "/bad.csv") << "time,dx,dy,dq\n0.01,0,0,0\n";
  std::ofstream(dir + "/scene.yaml")
      << scene("      - {clamp: start, keyframes: {file: path.csv}}\n", "",
               "grasps:\n  - {name: hand, keyframes: {file: path.csv}}\n");
  std::ofstream(dir + "/bad.yaml") << scene("      - {clamp: start, keyframes: {file: bad.csv}}\n");
  Scene s = load_scene(dir + "/scene.yaml");
  const Motion& m = *s.world.rods()[0].node_drive(0)->motion;
  EXPECT_LT((m.at(0.02).displacement - Vec3(0.01, 0, 0.01)).norm(), 1e-15);
  EXPECT_NEAR(m.at(0.02).rotation.w(), -1.0, 1e-12);  // one whole turn (q = -1)
  try {
    load_scene(dir + "/bad.yaml");
    ADD_FAILURE() << "bad.csv accepted";
  } catch (const SceneError& e) {
    EXPECT_NE(std::string(e.what()).find("bad.csv' line 1: unknown column 'dq'"), std::string::npos)
        << e.what();
  }
  // corde_run's loop: the grasp follows its keyframes, the reactions and energies are written.
  std::ostringstream reactions, energies;
  RunOptions o;
  o.reactions = &reactions;
  o.energies = &energies;
  o.every = 500;
  const Rod& rod = s.world.rods()[0];
  const Vec3 mid0 = 0.5 * (rod.positions()[9] + rod.positions()[10]);
  const RunResult r = run_scene(&s, o);
  ASSERT_TRUE(r.ok) << r.problem;
  const Vec3 mid = 0.5 * (rod.positions()[9] + rod.positions()[10]);
  EXPECT_LT((mid - mid0 - Vec3(0.01, 0, 0.01)).norm(), 1e-9);
  std::string header, line;
  std::istringstream rin(reactions.str()), ein(energies.str());
  std::getline(rin, header);
  EXPECT_EQ(header, "t,support,rod,fx,fy,fz,mx,my,mz,px,py,pz");
  int rows = 0;
  while (std::getline(rin, line)) ++rows;
  EXPECT_EQ(rows, 2 * 4);  // two supports at t = 0.005, 0.01, 0.015, 0.02
  std::getline(ein, header);
  EXPECT_EQ(header,
            "t,rod,kinetic_translation,kinetic_rotation,stretch,bend_twist,coupling,gravity,total");
  rows = 0;
  while (std::getline(ein, line)) ++rows;
  EXPECT_EQ(rows, 5);  // t = 0 too
  std::system(("rm -rf " + dir).c_str());
}

}  // namespace
}  // namespace corde
