// Every scene shipped in config/scenes/ parses without warnings, at a stable time step, and runs.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <string>
#include <vector>

#include "corde_sim/grasp.h"
#include "corde_sim/material.h"
#include "corde_sim/scene.h"
#include "corde_sim/stability.h"
#include "corde_sim/step_guard.h"

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
        "overhand_knot", "gripper_sweep", "tie_overhand_knot"})
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
    // Explicit methods: a margin below the stability limit, not just below it. (The implicit
    // method has none; the default scene runs it at 2 ms, over 100 times the explicit limit.)
    if (!is_implicit(s.world.integrator)) {
      for (const Rod& rod : s.world.rods())
        EXPECT_LE(s.world.time_step, 0.9 * critical_time_step(rod)) << rod.name();
    }
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

// The default scene is the real cord (no softened stretch or coupling) run implicitly at the
// robot's 2 ms frame; it sags from its arc and comes to rest without a guard event.
TEST(SceneFiles, DefaultSceneIsTheRealCordAtTwoMilliseconds) {
  Scene s = load_scene(std::string(CORDE_SIM_SOURCE_DIR) + "/config/scenes/default.yaml");
  EXPECT_EQ(s.world.integrator, Integrator::kImplicitEuler);
  EXPECT_DOUBLE_EQ(s.world.time_step, 0.002);
  const Material preset = material_preset("soft_cable").material;
  const Section real = make_section(preset, 0.003);
  const Rod& rod = s.world.rods()[0];
  EXPECT_DOUBLE_EQ(rod.section().stretch, real.stretch);
  EXPECT_DOUBLE_EQ(rod.section().kappa, real.kappa);
  for (const GraspSpec& spec : s.grasps) {
    Rod& r = s.world.rod(spec.rod);
    const Eigen::Isometry3d holder = segment_pose(r, grasp_segment(r, spec));
    hold(r, make_grasp(r, spec, holder), holder);
  }
  StepGuard guard;
  guard.reset(s.world);
  ASSERT_TRUE(guard.step(&s.world, 1000));  // 2 s
  EXPECT_TRUE(guard.events().empty());
  const WorldEnergies e = s.world.energies();
  EXPECT_LT(e.kinetic(), 1e-3 * e.elastic());  // at rest (damped by friction and the method)
}

}  // namespace
}  // namespace corde
