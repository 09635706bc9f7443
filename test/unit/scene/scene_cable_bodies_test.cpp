// Scene keys for what a real cable carries (docs/scene_format.md, "Cable bodies"): point masses
// and end bodies, density ranges, gravity_ramp; and material files (docs/scene_format.md,
// "Material files"), by name and by path, with errors naming the file and the key.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include "corde_sim/scene/scene.h"
#include "scene_test_util.h"

namespace corde {
namespace {

namespace fs = std::filesystem;

std::string with_rod_keys(const std::string& keys) {
  std::string s = test::kClampedCable;
  return s + keys;
}

TEST(SceneCableBodies, PointMassesAndAnEndBody) {
  const Scene s = parse_scene(with_rod_keys(
      "    masses:\n"
      "      - {node: 2, mass: 0.01}\n"
      "      - {node: end, mass: 0.02, inertia_across: 3.0e-6, inertia_along: 1.0e-6}\n"));
  const Scene plain = parse_scene(test::kClampedCable);
  const Rod& rod = s.world.rods()[0];
  const Rod& ref = plain.world.rods()[0];
  EXPECT_DOUBLE_EQ(rod.node_masses()[2] - ref.node_masses()[2], 0.01);
  EXPECT_DOUBLE_EQ(rod.node_masses()[4] - ref.node_masses()[4], 0.02);
  EXPECT_EQ(rod.node_masses()[1], ref.node_masses()[1]);
  const Vec3 added = rod.segment_inertia(3) - ref.segment_inertia(3);
  EXPECT_NEAR(added.x(), 3e-6, 1e-18);
  EXPECT_NEAR(added.y(), 3e-6, 1e-18);
  EXPECT_NEAR(added.z(), 1e-6, 1e-18);
  EXPECT_EQ(rod.segment_inertia(2), ref.segment_inertia(2));
  // A scene without the keys adds nothing (its arithmetic is the one before them).
  EXPECT_TRUE(ref.added_node_masses().empty());
  EXPECT_TRUE(ref.added_segment_inertias().empty());
  EXPECT_TRUE(ref.segment_mass_scale().empty());
}

TEST(SceneCableBodies, MassErrorsNameTheKey) {
  EXPECT_EQ(test::scene_error_of(
                with_rod_keys("    masses:\n      - {node: 2, mass: 0.01, inertia_across: 1e-6}\n"))
                .rfind("rods[0].masses[0].inertia_across: a rotary inertia needs an end node", 0),
            0u);
  EXPECT_EQ(test::scene_error_of(with_rod_keys("    masses:\n      - {node: 9, mass: 0.01}\n"))
                .rfind("rods[0].masses[0].node: node index '9' out of range (0..4", 0),
            0u);
  EXPECT_EQ(test::scene_error_of(with_rod_keys("    masses:\n      - {node: 1, mass: -1}\n"))
                .rfind("rods[0].masses[0].mass: must be > 0, got -1", 0),
            0u);
  EXPECT_EQ(test::scene_error_of(with_rod_keys("    masses:\n      - {node: 1}\n"))
                .rfind("rods[0].masses[0].mass: missing", 0),
            0u);
  EXPECT_EQ(test::scene_error_of(with_rod_keys("    masses:\n      - {node: 1, mass: 1, m: 2}\n"))
                .rfind("rods[0].masses[0].m: unknown key", 0),
            0u);
}

// masses[i].offset: the centre of mass off the end node in the end segment's frame; the body's
// inertia about the node gains the parallel-axis term, its weight turns the end segment.
TEST(SceneCableBodies, EndBodyOffset) {
  const Scene s = parse_scene(with_rod_keys(
      "    masses:\n"
      "      - {node: end, mass: 0.02, inertia_across: 3.0e-6, offset: [0, 0, 0.05]}\n"));
  const Scene plain = parse_scene(test::kClampedCable);
  const Rod& rod = s.world.rods()[0];
  const Rod& ref = plain.world.rods()[0];
  ASSERT_EQ(rod.mass_offsets().size(), 1u);
  EXPECT_EQ(rod.mass_offsets()[0].node, 4);
  EXPECT_EQ(rod.mass_offsets()[0].segment, 3);
  EXPECT_EQ(rod.mass_offsets()[0].offset, Vec3(0.0, 0.0, 0.05));
  const Vec3 added = rod.segment_inertia(3) - ref.segment_inertia(3);
  EXPECT_NEAR(added.x(), 3e-6 + 0.02 * 0.05 * 0.05, 1e-18);
  EXPECT_NEAR(added.z(), 0.0, 1e-18);
  EXPECT_DOUBLE_EQ(rod.node_masses()[4] - ref.node_masses()[4], 0.02);
  EXPECT_TRUE(ref.mass_offsets().empty());
  // Under gravity the offset weight turns the end segment (its body torque m d x R^T g).
  const Vec3 g(0.0, 0.0, -9.81);
  // The rod lies along x: the offset is horizontal, its arm whole.
  EXPECT_NEAR(rod.mass_offset_torque(3, g).norm(), 0.02 * 0.05 * 9.81, 1e-12);
  EXPECT_EQ(rod.mass_offset_torque(2, g), Vec3::Zero());
}

TEST(SceneCableBodies, OffsetErrorsNameTheKey) {
  const std::string nan = test::scene_error_of(
      with_rod_keys("    masses:\n      - {node: end, mass: 0.01, offset: [0, .nan, 0.01]}\n"));
  EXPECT_EQ(nan.rfind("rods[0].masses[0].offset", 0), 0u) << nan;
  EXPECT_NE(nan.find("finite"), std::string::npos) << nan;
  const std::string far = test::scene_error_of(
      with_rod_keys("    masses:\n      - {node: end, mass: 0.01, offset: [0, 0, 50]}\n"));
  EXPECT_EQ(far.rfind("rods[0].masses[0].offset: must be at most 10 times the rod's length", 0), 0u)
      << far;
  const std::string inner = test::scene_error_of(
      with_rod_keys("    masses:\n      - {node: 2, mass: 0.01, offset: [0, 0, 0.01]}\n"));
  EXPECT_EQ(inner.rfind("rods[0].masses[0].offset: an offset needs an end node", 0), 0u) << inner;
  const std::string shape = test::scene_error_of(
      with_rod_keys("    masses:\n      - {node: end, mass: 0.01, offset: 0.02}\n"));
  EXPECT_EQ(shape.rfind("rods[0].masses[0].offset: expected [x, y, z]", 0), 0u) << shape;
}

TEST(SceneCableBodies, DensityRangesScaleTheSegmentsTheyCover) {
  // 0.2 m in 4 segments of 0.05 m: [0.05, 0.075] covers half of segment 1.
  const Scene s = parse_scene(
      with_rod_keys("    density_ranges:\n      - {from: 0.05, to: 0.075, rho: 6000}\n"));
  const Rod& rod = s.world.rods()[0];
  const double rho = 2000.0;  // soft_cable
  ASSERT_EQ(rod.segment_mass_scale().size(), 4u);
  EXPECT_EQ(rod.segment_mass_scale()[0], 1.0);
  EXPECT_NEAR(rod.segment_mass_scale()[1], 0.5 + 0.5 * 6000.0 / rho, 1e-12);
  EXPECT_EQ(rod.segment_mass_scale()[2], 1.0);
  double total = 0.0;
  for (double m : rod.node_masses()) total += m;
  const double mu = rod.section().mass_per_length;
  EXPECT_NEAR(total, mu * 0.2 + mu * 0.025 * (6000.0 / rho - 1.0), 1e-12 * total);

  EXPECT_EQ(
      test::scene_error_of(
          with_rod_keys("    density_ranges:\n      - {from: 0.3, to: 0.4, rho: 100}\n"))
          .rfind("rods[0].density_ranges[0]: starts at 0.3 m, beyond the rod's rest length", 0),
      0u);
  EXPECT_EQ(test::scene_error_of(
                with_rod_keys("    density_ranges:\n      - {from: 0.1, to: 0.1, rho: 100}\n"))
                .rfind("rods[0].density_ranges[0].to: must be greater than from (0.1 m)", 0),
            0u);
  EXPECT_EQ(
      test::scene_error_of(with_rod_keys("    density_ranges:\n      - {from: 0, to: 0.1, "
                                         "rho: 100}\n      - {from: 0.05, to: 0.2, rho: 1}\n"))
          .rfind("rods[0].density_ranges[1]: overlaps rods[0].density_ranges[0] ([0, 0.1] m)", 0),
      0u);
  EXPECT_EQ(test::scene_error_of(
                with_rod_keys("    density_ranges:\n      - {from: 0, to: 0.1, rho: 1e9}\n"))
                .rfind("rods[0].density_ranges[0].rho: must be <= 100000 kg/m^3", 0),
            0u);
}

TEST(SceneCableBodies, GravityRamp) {
  const Scene s = parse_scene(std::string("gravity_ramp: 0.5\n") + test::kClampedCable);
  EXPECT_EQ(s.world.gravity_ramp, 0.5);
  EXPECT_EQ(parse_scene(test::kClampedCable).world.gravity_ramp, 0.0);
  EXPECT_EQ(test::scene_error_of(std::string("gravity_ramp: -1\n") + test::kClampedCable)
                .rfind("gravity_ramp: must be >= 0", 0),
            0u);
  // A rod settled at t = 0 under a ramp from zero starts straight: its equilibrium is unloaded.
  const Scene settled = parse_scene(std::string("gravity_ramp: 0.5\ninitial_state: equilibrium\n") +
                                    test::kClampedCable);
  EXPECT_NEAR(settled.world.rods()[0].positions()[4].z(), 1.0, 1e-12);
}

// A folder with a scene and its materials/ folder, removed at the end.
class MaterialFiles : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("corde_material_files_" +
            std::to_string(::testing::UnitTest::GetInstance()->random_seed()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_ / "materials");
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string write(const std::string& name, const std::string& text) {
    const fs::path p = dir_ / name;
    std::ofstream(p) << text;
    return p.string();
  }
  // The clamped cable with `material` as given and no radius key unless `radius` is.
  std::string scene(const std::string& material, const std::string& extra = "") {
    return write("scene.yaml",
                 "time_step: 1.0e-5\nduration: 0.002\nrods:\n  - name: cable\n"
                 "    elements: 4\n    material: " +
                     material + "\n" + extra +
                     "    shape: {type: straight, start: [0, 0, 1], direction: [1, "
                     "0, 0], length: 0.2}\n    boundary:\n      - {clamp: start}\n");
  }
  std::string error_of(const std::string& path) {
    try {
      load_scene(path);
    } catch (const SceneError& e) {
      return e.what();
    }
    return "";
  }
  fs::path dir_;
};

constexpr const char* kFitted = R"(# written by corde_fit
version: 1
name: my_cable
description: a 6 mm cable, fitted
radius: 0.003
E: 3.0e7
G: 1.0e7
E_s: 5.0e9
rho: 1500
damping_time: 1.0e-4
drag: {linear_normal: 0.02}
friction: 0.3
fit: {residual_rms: 0.0011, samples: 400}
)";

TEST_F(MaterialFiles, ByNameFromTheMaterialsFolderGivesTheSameRodAsTheMap) {
  write("materials/my_cable.yaml", kFitted);
  const Scene by_name = load_scene(scene("my_cable"));
  const Scene by_map = load_scene(
      scene("{E: 3.0e7, G: 1.0e7, E_s: 5.0e9, rho: 1500, damping_time: 1.0e-4}",
            "    radius: 0.003\n    drag: {linear_normal: 0.02}\n    contact: {friction: 0.3}\n"));
  const Rod& a = by_name.world.rods()[0];
  const Rod& b = by_map.world.rods()[0];
  EXPECT_EQ(a.section().radius, 0.003);
  EXPECT_EQ(a.section().bend, b.section().bend);
  EXPECT_EQ(a.section().twist, b.section().twist);
  EXPECT_EQ(a.section().stretch, b.section().stretch);
  EXPECT_EQ(a.section().gamma_r, b.section().gamma_r);
  EXPECT_EQ(a.section().mass_per_length, b.section().mass_per_length);
  EXPECT_EQ(a.drag().linear_normal, 0.02);
  EXPECT_EQ(a.contact_options().friction, 0.3);
  // By path, relative to the scene's folder, the same.
  const Scene by_path = load_scene(scene("{file: materials/my_cable.yaml}"));
  EXPECT_EQ(by_path.world.rods()[0].section().bend, b.section().bend);
}

TEST_F(MaterialFiles, SceneKeysOverrideTheFile) {
  write("materials/my_cable.yaml", kFitted);
  const Scene s = load_scene(scene("{file: materials/my_cable.yaml, B: 1.0e-3, rho: 1000}",
                                   "    radius: 0.004\n    drag: {linear_normal: 0.5}\n"
                                   "    contact: {friction: 0.1}\n"));
  const Rod& rod = s.world.rods()[0];
  EXPECT_EQ(rod.section().radius, 0.004);
  EXPECT_EQ(rod.section().bend, 1.0e-3);
  EXPECT_NEAR(rod.section().mass_per_length, 1000.0 * M_PI * 0.004 * 0.004, 1e-15);
  EXPECT_NEAR(rod.section().twist, 1.0e7 * M_PI * std::pow(0.004, 4) / 2.0, 1e-15);
  EXPECT_EQ(rod.drag().linear_normal, 0.5);
  EXPECT_EQ(rod.contact_options().friction, 0.1);
}

TEST_F(MaterialFiles, ErrorsNameTheFileAndTheKey) {
  const std::string file = write("materials/bad.yaml", "radius: 0.003\nE: -5\nG: 1e7\nrho: 1000\n");
  EXPECT_EQ(error_of(scene("bad")),
            "rods[0].material: material file '" + file +
                "': E: must be > 0, got -5 (valid: (0, 1e+30] Pa) (line 2)");
  write("materials/typo.yaml", "radius: 0.003\nE: 1e7\nG: 1e7\nrho: 1000\ndensity: 3\n");
  EXPECT_NE(error_of(scene("typo"))
                .find("material file '" + (dir_ / "materials/typo.yaml").string() +
                      "': density: unknown key"),
            std::string::npos)
      << error_of(scene("typo"));
  write("materials/syntax.yaml", "E: [1, 2\n");
  EXPECT_NE(error_of(scene("syntax")).find("YAML syntax error"), std::string::npos);
  write("materials/thin.yaml", "radius: 0.003\nE: 1e7\nrho: 1000\n");
  EXPECT_NE(error_of(scene("thin")).find("rods[0].material: needs G, nu or C (material file '"),
            std::string::npos)
      << error_of(scene("thin"));
  // A name that is neither a preset nor a file names both places it looked.
  const std::string unknown = error_of(scene("no_such_cable"));
  EXPECT_NE(unknown.find("rods[0].material: unknown material preset"), std::string::npos)
      << unknown;
  EXPECT_NE(unknown.find("no material file '" + (dir_ / "materials/no_such_cable.yaml").string() +
                         "' either"),
            std::string::npos)
      << unknown;
  const std::string missing = error_of(scene("{file: nowhere.yaml}"));
  EXPECT_EQ(missing.rfind("rods[0].material.file: " + (dir_ / "nowhere.yaml").string(), 0), 0u)
      << missing;
  EXPECT_NE(error_of(scene("{file: materials/bad.yaml, preset: soft_cable}"))
                .find("give either preset or file, not both"),
            std::string::npos);
}

}  // namespace
}  // namespace corde
