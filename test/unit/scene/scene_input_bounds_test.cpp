// Hostile and careless scene input (issue 22): values that are finite but absurd (alone or in
// products), FIFOs and devices as scene or keyframe files, byte order marks, keyframe-file
// messages, rods that start inside an obstacle.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <future>
#include <string>
#include <vector>

#include "corde_sim/scene/scene.h"
#include "scene_test_util.h"

namespace corde {
namespace {

const char* const kScene = test::kClampedCable;
using test::scene_error_of;

bool starts_with(const std::string& text, const std::string& head) {
  return text.rfind(head, 0) == 0;
}

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

std::string temp_path(const std::string& name) {
  return ::testing::TempDir() + "scene_input_" + std::to_string(getpid()) + "_" + name;
}

void write_file(const std::string& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

// --- Products of individually valid values (item 2) ---------------------------------------------

TEST(SceneInputBounds, DragProductsThatOverflowNameTheKey) {
  // Each value alone is accepted; their product (rho C_f pi r) overflowed to infinity and
  // Rod::set_drag threw std::invalid_argument, which aborted corde_run.
  const std::string f =
      scene_error_of(kScene, {"rods.0.drag={fluid_density: 1000, friction_coefficient: 1e308}"});
  EXPECT_TRUE(starts_with(f, "rods[0].drag.friction_coefficient: ")) << f;
  const std::string d =
      scene_error_of(kScene, {"rods.0.drag={fluid_density: 1e308, drag_coefficient: 10}"});
  EXPECT_TRUE(starts_with(d, "rods[0].drag.fluid_density: ")) << d;
  // Sensible values still load.
  EXPECT_EQ(scene_error_of(kScene, {"rods.0.drag={fluid_density: 1.2, drag_coefficient: 1.2, "
                                    "friction_coefficient: 0.01}"}),
            "");
}

// Every override gives a finite but absurd value: each must be a SceneError naming its key.
TEST(SceneInputBounds, AbsurdValuesAreRefusedNamingTheKey) {
  const std::string with_obstacle = std::string(kScene) +
                                    "obstacles:\n  - {type: sphere, "
                                    "position: [0, 0, -1], radius: 0.1}\n";
  struct Case {
    std::string override_text, key;
  } cases[] = {
      {"gravity=[0, 0, -1e300]", "gravity"},
      {"rods.0.radius=1e300", "rods[0].radius"},
      {"rods.0.shape.length=1e300", "rods[0].shape.length"},
      {"rods.0.shape.start=[1e300, 0, 0]", "rods[0].shape.start"},
      {"rods.0.shape={type: polyline, points: [[0, 0, 0], [1e300, 0, 0]]}",
       "rods[0].shape.points[1]"},
      {"rods.0.shape={type: helix, radius: 1e300, pitch: 0.1, turns: 2}", "rods[0].shape.radius"},
      {"rods.0.shape={type: helix, radius: 0.1, pitch: 0.1, turns: 1e300}", "rods[0].shape.turns"},
      {"rods.0.material.E=1e300", "rods[0].material.E"},
      {"rods.0.material.rho=1e300", "rods[0].material.rho"},
      // A tiny density made the start's energy per mass 8e277 J/kg (a runaway at step 0).
      {"rods.0.material.rho=1e-300", "rods[0].material.rho"},
      {"rods.0.material.B=1e300", "rods[0].material.B"},
      {"rods.0.material.damping_time=1e300", "rods[0].material.damping_time"},
      {"rods.0.drag={linear_normal: 1e300}", "rods[0].drag.linear_normal"},
      {"rods.0.loads=[{node: end, force: [0, 0, 1e300]}]", "rods[0].loads[0].force"},
      {"rods.0.loads=[{segment: end, torque: [0, 0, 1e300]}]", "rods[0].loads[0].torque"},
      {"rods.0.initial={velocity: [1e300, 0, 0]}", "rods[0].initial.velocity"},
      {"rods.0.initial={angular_velocity: [1e300, 0, 0]}", "rods[0].initial.angular_velocity"},
      {"rods.0.initial={perturbation: {position: 1e300}}", "rods[0].initial.perturbation.position"},
      {"rods.0.boundary=[{node: end, velocity: [1e300, 0, 0]}]", "rods[0].boundary[0].velocity"},
      {"rods.0.boundary=[{segment: end, spin_rate: 1e300}]", "rods[0].boundary[0].spin_rate"},
      {"rods.0.boundary=[{clamp: start, move_by: [1e300, 0, 0], ramp_time: 1}]",
       "rods[0].boundary[0].move_by"},
      {"rods.0.boundary=[{clamp: start, move_by: [0.1, 0, 0], ramp_time: 1e-300}]",
       "rods[0].boundary[0].ramp_time"},
      {"rods.0.boundary=[{clamp: start, turns: 1e300, ramp_time: 1}]", "rods[0].boundary[0].turns"},
      {"rods.0.boundary=[{clamp: start, keyframes: [{time: 1, position: [1e300, 0, 0]}]}]",
       "rods[0].boundary[0].keyframes[0].position"},
      {"rods.0.boundary=[{clamp: start, keyframes: [{time: 1e-300, displacement: [1, 0, 0]}]}]",
       "rods[0].boundary[0].keyframes[0].time"},
      {"obstacles.0.radius=1e308", "obstacles[0].radius"},
      {"obstacles.0.position=[0, 0, 1e308]", "obstacles[0].position"},
      {"obstacles.0={type: box, size: [1e308, 1, 1]}", "obstacles[0].size"},
      {"obstacles.0={type: plane, position: [0, 0, -1e308]}", "obstacles[0].position"},
      {"obstacles.0={type: cylinder, radius: 0.1, length: 1e308}", "obstacles[0].length"},
      {"obstacles.0={type: capsule, radius: 1e308, length: 1}", "obstacles[0].radius"},
      {"obstacles.0.friction=1e300", "obstacles[0].friction"},
      {"contact={skin: 1e300}", "contact.skin"},
      {"contact={max_push_speed: 1e300}", "contact.max_push_speed"},
      {"duration=1e300", "duration"},
  };
  for (const Case& c : cases) {
    const std::string e = scene_error_of(with_obstacle, {c.override_text});
    EXPECT_TRUE(starts_with(e, c.key + ": ")) << c.override_text << " -> " << e;
  }
  EXPECT_EQ(scene_error_of(with_obstacle), "");
}

// A URDF link placed far away (its joint's origin) is refused by where it ends up, naming the
// entry.
TEST(SceneInputBounds, ObstaclesPlacedFarAwayAreRefused) {
  const std::string urdf = temp_path("far.urdf");
  write_file(urdf, R"(<robot name="far"><link name="base"/>
<link name="away"><collision><geometry><box size="1 1 1"/></geometry></collision></link>
<joint name="j" type="fixed"><parent link="base"/><child link="away"/>
<origin xyz="1e6 0 0" rpy="0 0 0"/></joint></robot>)");
  const std::string e =
      scene_error_of(std::string(kScene) + "obstacles:\n  - {name: r, urdf: '" + urdf + "'}\n");
  std::remove(urdf.c_str());
  EXPECT_TRUE(starts_with(e, "obstacles[0]")) << e;
}

// --- Files that are not regular files (item 11) -------------------------------------------------

// Runs `f` with a time limit; a FIFO that blocks the reader is unblocked by opening its write end.
template <typename F>
std::string within_seconds(double seconds, const std::string& fifo, F f) {
  auto result = std::async(std::launch::async, f);
  if (result.wait_for(std::chrono::duration<double>(seconds)) == std::future_status::ready)
    return result.get();
  const int fd = open(fifo.c_str(), O_WRONLY | O_NONBLOCK);  // lets the blocked open() return
  if (fd >= 0) close(fd);
  result.wait();
  return "TIMED OUT (blocked on the FIFO)";
}

TEST(SceneInputFiles, FifoAsSceneFileIsRefusedAtOnce) {
  const std::string fifo = temp_path("scene.fifo");
  std::remove(fifo.c_str());
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  const std::string e = within_seconds(5.0, fifo, [&] {
    try {
      load_scene(fifo);
    } catch (const SceneError& e) {
      return std::string(e.what());
    }
    return std::string();
  });
  std::remove(fifo.c_str());
  EXPECT_TRUE(contains(e, "is not a regular file")) << e;
}

TEST(SceneInputFiles, FifoAsKeyframeFileIsRefusedAtOnce) {
  const std::string fifo = temp_path("keys.fifo");
  std::remove(fifo.c_str());
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  const std::string scene =
      std::string(kScene) + "      - {node: end, keyframes: {file: '" + fifo + "'}}\n";
  const std::string e = within_seconds(5.0, fifo, [&] { return scene_error_of(scene); });
  std::remove(fifo.c_str());
  EXPECT_TRUE(starts_with(e, "rods[0].boundary[1].keyframes: ")) << e;
  EXPECT_TRUE(contains(e, "is not a regular file")) << e;
}

TEST(SceneInputFiles, DevicesAreRefused) {
  std::string e;
  try {
    load_scene("/dev/zero");
  } catch (const SceneError& ex) {
    e = ex.what();
  }
  EXPECT_EQ(e, "/dev/zero: is not a regular file (a FIFO, socket or device), not a scene file");
  e = scene_error_of(std::string(kScene) + "      - {node: end, keyframes: {file: /dev/zero}}\n");
  EXPECT_TRUE(contains(e, "/dev/zero: is not a regular file")) << e;
}

TEST(SceneInputFiles, KeyframeFileSizeLimit) {
  const std::string path = temp_path("big.csv");
  write_file(path, "time,dx,dy,dz\n" + std::string(SceneLimits::max_keyframe_file_bytes, '#'));
  const std::string e = scene_error_of(std::string(kScene) +
                                       "      - {node: end, keyframes: {file: '" + path + "'}}\n");
  std::remove(path.c_str());
  EXPECT_TRUE(contains(e, "larger than the limit of 1048576 bytes for a keyframe file")) << e;
}

// --- Messages (item 14) --------------------------------------------------------------------------

TEST(SceneInputMessages, KeyframeFileErrorsNameTheFileAndLine) {
  const std::string path = temp_path("order.csv");
  write_file(path, "time,dx,dy,dz\n# comment\n0.2,0,0,0.01\n0.1,0,0,0.02\n");
  const std::string e = scene_error_of(std::string(kScene) +
                                       "      - {node: end, keyframes: {file: '" + path + "'}}\n");
  EXPECT_TRUE(starts_with(e, "rods[0].boundary[1].keyframes: '" + path + "' line 4: ")) << e;
  EXPECT_TRUE(contains(e, "times must increase strictly")) << e;
  // A keyframe at time 0 that is not the start pose: its line too.
  write_file(path, "time,dx,dy,dz\n0,0,0,0.01\n");
  const std::string z = scene_error_of(std::string(kScene) +
                                       "      - {node: end, keyframes: {file: '" + path + "'}}\n");
  std::remove(path.c_str());
  EXPECT_TRUE(contains(z, "'" + path + "' line 2: ")) << z;
  // Keyframes in the scene: the item's path.
  const std::string l =
      scene_error_of(std::string(kScene) +
                     "      - {node: end, keyframes: [{time: 0.2, displacement: [0, "
                     "0, 0]}, {time: 0.1, displacement: [0, 0, 0]}]}\n");
  EXPECT_TRUE(starts_with(l, "rods[0].boundary[1].keyframes[1]: times must increase strictly"))
      << l;
}

TEST(SceneInputMessages, ByteOrderMarkIsAccepted) {
  const std::string bom = "\xEF\xBB\xBF";
  const std::string csv = temp_path("bom.csv");
  write_file(csv, bom + "time,dx,dy,dz\n0.001,0,0,0.001\n");
  const std::string scene_path = temp_path("bom.yaml");
  write_file(scene_path, bom + kScene + "      - {node: end, keyframes: {file: '" + csv + "'}}\n");
  std::string e;
  try {
    const Scene s = load_scene(scene_path);
    EXPECT_EQ(s.world.rods()[0].num_segments(), 4);
  } catch (const SceneError& ex) {
    e = ex.what();
  }
  std::remove(csv.c_str());
  std::remove(scene_path.c_str());
  EXPECT_EQ(e, "");
}

TEST(SceneInputMessages, OverrideMessagesGiveTheKeyOnce) {
  const std::string scene = std::string(kScene) + "obstacles:\n  - {urdf: robot.urdf}\n";
  const std::string e = scene_error_of(scene, {"obstacles.0.urdf="});
  EXPECT_TRUE(starts_with(e, "obstacles[0].urdf: ")) << e;
  EXPECT_EQ(e.find("obstacles[0].urdf", 1), std::string::npos) << e;
  EXPECT_TRUE(contains(e, "(set by override 'obstacles.0.urdf=')")) << e;
}

// A rod that starts inside an obstacle ran into a speed runaway (112 m/s) at once; it is refused
// at load, naming the rod, the depth and the obstacle. Touching (within 1% of the radius) is fine.
TEST(SceneInputMessages, RodStartingInsideAnObstacleIsRefused) {
  const double r = 0.003;  // soft_cable's radius
  auto scene_at = [&](double z) {
    return std::string(kScene) + "obstacles:\n  - {name: table, type: box, position: [0, 0, " +
           std::to_string(z) + "], size: [2, 2, 1]}\n";
  };
  // The rod's axis is at z = 1: the table's top at z + 0.5.
  const std::string inside = scene_error_of(scene_at(0.5 + 0.5 * r));
  EXPECT_TRUE(starts_with(inside, "rods[0]: ")) << inside;
  EXPECT_TRUE(contains(inside, "starts inside obstacle 'table' (obstacles[0])")) << inside;
  EXPECT_TRUE(contains(inside, "0.0045 m deep")) << inside;
  EXPECT_EQ(scene_error_of(scene_at(0.5 - r)), "");          // resting on it
  EXPECT_EQ(scene_error_of(scene_at(0.5 - 0.995 * r)), "");  // within 1% of the radius
  EXPECT_EQ(scene_error_of(scene_at(0.5 - 0.98 * r)).rfind("rods[0]: ", 0), 0u);
  // Without obstacle contact for the rod, the overlap does not matter.
  EXPECT_EQ(scene_error_of(scene_at(0.5 + 0.5 * r), {"rods.0.contact={obstacles: false}"}), "");
}

}  // namespace
}  // namespace corde
