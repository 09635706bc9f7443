// Every scene shipped in config/scenes/ parses without warnings, at a stable time step, and runs.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <string>
#include <vector>

#include "corde_sim/scene.h"
#include "corde_sim/stability.h"

#ifndef CORDE_SIM_SOURCE_DIR
// Fallback when built without CMake's definition: this file is <root>/test/unit/.
#define CORDE_SIM_SOURCE_DIR \
  (std::filesystem::path(__FILE__).parent_path().parent_path().parent_path().string())
#endif

namespace corde {
namespace {

std::vector<std::string> scene_files() {
  std::vector<std::string> files;
  const std::filesystem::path dir = std::filesystem::path(CORDE_SIM_SOURCE_DIR) / "config/scenes";
  for (const auto& entry : std::filesystem::directory_iterator(dir))
    if (entry.path().extension() == ".yaml") files.push_back(entry.path().string());
  std::sort(files.begin(), files.end());
  return files;
}

TEST(SceneFiles, DirectoryHoldsTheExpectedScenes) {
  std::vector<std::string> names;
  for (const std::string& f : scene_files())
    names.push_back(std::filesystem::path(f).stem().string());
  for (const char* want :
       {"default", "coiling_50", "coiling_100", "coiling_1000", "preshaped_spring",
        "preshaped_wire", "thread", "helical_buckling", "plectoneme", "plectoneme_contact",
        "lift_and_lay", "rope_pendulum_air", "drape_table", "rod_stack", "rope_pile",
        "overhand_knot", "gripper_sweep"})
    EXPECT_NE(std::find(names.begin(), names.end(), want), names.end()) << want;
}

TEST(SceneFiles, EveryFileParsesAndRuns) {
  const std::vector<std::string> files = scene_files();
  ASSERT_FALSE(files.empty());
  for (const std::string& f : files) {
    SCOPED_TRACE(f);
    Scene s;
    ASSERT_NO_THROW(s = load_scene(f)) << f;
    EXPECT_FALSE(s.description.empty());
    for (const std::string& w : s.warnings) ADD_FAILURE() << "warning: " << w;
    // A margin below the stability limit, not just below it.
    for (const Rod& rod : s.world.rods())
      EXPECT_LE(s.world.time_step, 0.9 * critical_time_step(rod)) << rod.name();
    for (const GraspSpec& g : s.grasps) EXPECT_NO_THROW(s.world.rod(g.rod));
    s.world.step(50);
    EXPECT_TRUE(s.world.finite());
  }
}

TEST(SceneFiles, DefaultSceneHasTheGripper) {
  const Scene s = load_scene(std::string(CORDE_SIM_SOURCE_DIR) + "/config/scenes/default.yaml");
  ASSERT_EQ(s.grasps.size(), 1u);
  EXPECT_EQ(s.grasps[0].name, "gripper");
}

}  // namespace
}  // namespace corde
