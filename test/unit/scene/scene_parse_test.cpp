// Scenes parse into the world they describe: shapes, materials, boundaries, loads, grasps,
// overrides, defaults.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "corde_sim/scene/scene.h"
#include "corde_sim/stability/explicit_step_limit.h"

namespace corde {
namespace {

constexpr double kPi = 3.14159265358979323846;

std::string rod_scene(const std::string& rod_body, const std::string& extra = "") {
  return "time_step: 1.0e-6\nrods:\n  - name: r\n" + rod_body + extra;
}

const char* kMaterial =
    "    material: {E: 1.0e7, G: 3.0e6, E_s: 2.0e7, rho: 1000}\n    radius: 0.01\n";

TEST(SceneParse, DefaultsOfAMinimalScene) {
  const Scene s = parse_scene("rods:\n  - {material: soft_cable, shape: {type: straight}}\n");
  EXPECT_EQ(s.name, "scene");
  EXPECT_EQ(s.world.gravity, Vec3(0, 0, -9.81));
  EXPECT_EQ(s.duration, 1.0);
  ASSERT_EQ(s.world.rods().size(), 1u);
  const Rod& rod = s.world.rods()[0];
  EXPECT_EQ(rod.name(), "rod0");
  EXPECT_EQ(rod.num_segments(), 50);
  EXPECT_DOUBLE_EQ(rod.section().radius, material_preset("soft_cable").radius);
  EXPECT_NEAR(rod.length(), 1.0, 1e-12);
  // No time_step: 0.8 of the estimated stability limit.
  EXPECT_NEAR(s.world.time_step, 0.8 * critical_time_step(rod), 1e-18);
  EXPECT_TRUE(s.warnings.empty());
  EXPECT_TRUE(s.grasps.empty());
}

TEST(SceneParse, StraightShape) {
  const Scene s =
      parse_scene(rod_scene(std::string(kMaterial) +
                            "    elements: 8\n    shape: {type: straight, start: [1, 2, "
                            "3], direction: [0, 3, 4], length: 2.5}\n"));
  const Rod& rod = s.world.rods()[0];
  ASSERT_EQ(rod.num_nodes(), 9);
  for (int i = 0; i <= 8; ++i)
    EXPECT_LT((rod.positions()[i] - (Vec3(1, 2, 3) + 2.5 * i / 8.0 * Vec3(0, 0.6, 0.8))).norm(),
              1e-12);
  EXPECT_LT((rod.orientations()[3] * Vec3::UnitZ() - Vec3(0, 0.6, 0.8)).norm(), 1e-12);
}

TEST(SceneParse, HelixByTurnsAndByLength) {
  const std::string helix =
      "    elements: 60\n    shape: {type: helix, start: [0, 0, 0], axis: [0, "
      "0, 2], radius: 0.05, pitch: 0.02, ";
  const Scene a = parse_scene(rod_scene(kMaterial + helix + "turns: 3}\n"));
  const Rod& rod = a.world.rods()[0];
  for (const Vec3& x : rod.positions()) EXPECT_NEAR(x.head<2>().norm(), 0.05, 1e-12);
  EXPECT_NEAR(rod.positions().back().z(), 0.06, 1e-12);
  const double per_turn = std::hypot(2 * kPi * 0.05, 0.02);
  // 60 equal chords of the helix, each spanning 2 pi / 20 of angle.
  const double dphi = 2 * kPi / 20;
  const double chord = std::hypot(2 * 0.05 * std::sin(dphi / 2), 0.02 * dphi / (2 * kPi));
  EXPECT_NEAR(rod.length(), 60 * chord, 1e-12);
  const Scene b = parse_scene(rod_scene(kMaterial + helix + "length: 0.5}\n"));
  EXPECT_NEAR(b.world.rods()[0].positions().back().z(), 0.02 * 0.5 / per_turn, 1e-12);
}

TEST(SceneParse, PolylineAndReferenceDirector) {
  const Scene s = parse_scene(rod_scene(
      std::string(kMaterial) +
      "    elements: 4\n    reference_d1: [0, 1, 5]\n    shape: {type: polyline, points: [[0, 0, "
      "0], [1, 0, 0], [1, 1, 0]]}\n"));
  const Rod& rod = s.world.rods()[0];
  EXPECT_LT((rod.positions()[0] - Vec3(0, 0, 0)).norm(), 1e-12);
  EXPECT_LT((rod.positions()[2] - Vec3(1, 0, 0)).norm(), 1e-12);
  EXPECT_LT((rod.positions()[4] - Vec3(1, 1, 0)).norm(), 1e-12);
  // d1 of the first segment: reference_d1 made perpendicular to the tangent x.
  const Vec3 d1 = rod.orientations()[0].toRotationMatrix().col(0);
  EXPECT_LT((d1 - Vec3(0, 1, 5).normalized()).norm(), 1e-12);
}

TEST(SceneParse, RestShape) {
  const std::string helix =
      "    elements: 40\n    shape: {type: helix, radius: 0.05, pitch: 0.02, turns: 2}\n";
  const Scene straight = parse_scene(rod_scene(kMaterial + helix));
  for (const Vec3& u : straight.world.rods()[0].rest_strains()) EXPECT_EQ(u.norm(), 0.0);
  const Scene created = parse_scene(rod_scene(kMaterial + helix + "    rest_shape: created\n"));
  // Curvature of a helix: R / (R^2 + (p / 2 pi)^2).
  const double c = 0.02 / (2 * kPi), k = 0.05 / (0.05 * 0.05 + c * c);
  for (const Vec3& u : created.world.rods()[0].rest_strains())
    EXPECT_NEAR(u.head<2>().norm(), k, 0.01 * k);
}

TEST(SceneParse, MaterialFromModuli) {
  const Scene s = parse_scene(
      rod_scene("    radius: 0.01\n    material: {E: 1.0e7, nu: 0.5, rho: 1000}\n    shape: {type: "
                "straight}\n"));
  const Section& sec = s.world.rods()[0].section();
  const double r = 0.01, area = kPi * r * r, i = area * r * r / 4;
  EXPECT_DOUBLE_EQ(sec.bend, 1e7 * i);
  EXPECT_DOUBLE_EQ(sec.twist, 1e7 / 3.0 * 2 * i);
  EXPECT_DOUBLE_EQ(sec.stretch, 1e7 * area);       // E_s defaults to E
  EXPECT_NEAR(sec.kappa, 1e7 / 3.0 * area, 1e-9);  // kappa defaults to G A
  EXPECT_DOUBLE_EQ(sec.mass_per_length, 1000 * area);
  EXPECT_EQ(sec.gamma_t, 0.0);
  EXPECT_EQ(sec.gamma_r, 0.0);
}

TEST(SceneParse, MaterialDirectStiffnessAndDampingTime) {
  const Scene s = parse_scene(rod_scene(
      "    radius: 0.002\n    material: {B: 0.5, C: 0.25, K_s: 1000, kappa: 300, rho: 1200, "
      "damping_time: 0.002}\n    shape: {type: straight}\n"));
  const Section& sec = s.world.rods()[0].section();
  EXPECT_DOUBLE_EQ(sec.bend, 0.5);
  EXPECT_DOUBLE_EQ(sec.twist, 0.25);
  EXPECT_DOUBLE_EQ(sec.stretch, 1000);
  EXPECT_DOUBLE_EQ(sec.kappa, 300);
  EXPECT_DOUBLE_EQ(sec.gamma_t, 0.002 * 1000);  // tau K_s = tau E_s A
  EXPECT_DOUBLE_EQ(sec.gamma_r, 0.002 * 0.5);   // tau B = tau E I
}

TEST(SceneParse, ExplicitFrictionOverridesDampingTime) {
  const Scene s = parse_scene(
      "rods: [{material: {preset: soft_cable, damping_time: 0.001, gamma_t: 0.2}, shape: {type: "
      "straight}}]");
  const Section& sec = s.world.rods()[0].section();
  EXPECT_DOUBLE_EQ(sec.gamma_t, 0.2);
  EXPECT_DOUBLE_EQ(sec.gamma_r, 0.001 * sec.bend);
}

TEST(SceneParse, PresetByNameMatchesLibrary) {
  const Scene s = parse_scene(rod_scene("    material: paper_rope\n    shape: {type: straight}\n"));
  const MaterialPreset& p = material_preset("paper_rope");
  const Section want = make_section(p.material, p.radius);
  const Section& got = s.world.rods()[0].section();
  EXPECT_DOUBLE_EQ(got.radius, p.radius);
  EXPECT_NEAR(got.bend, want.bend, 1e-12 * want.bend);
  EXPECT_NEAR(got.twist, want.twist, 1e-12 * want.twist);
  EXPECT_NEAR(got.stretch, want.stretch, 1e-12 * want.stretch);
  EXPECT_NEAR(got.kappa, want.kappa, 1e-12 * want.kappa);
  EXPECT_NEAR(got.gamma_t, want.gamma_t, 1e-12 * want.gamma_t);
  EXPECT_NEAR(got.gamma_r, want.gamma_r, 1e-12 * want.gamma_r);
}

TEST(SceneParse, PresetAtAnotherRadiusKeepsItsIntent) {
  // Half the preset's radius: kappa (= G A) and gamma_t (= tau E_s A) scale with r^2, gamma_r
  // (= tau E I) with r^4; an overridden field wins.
  const MaterialPreset& p = material_preset("nylon_rope");
  const Section base = make_section(p.material, p.radius);
  const double r = 0.5 * p.radius;
  const Scene s = parse_scene(rod_scene("    radius: " + std::to_string(r) +
                                        "\n    material: {preset: nylon_rope, rho: 900}\n    "
                                        "shape: {type: straight}\n"));
  const Section& got = s.world.rods()[0].section();
  EXPECT_NEAR(got.kappa, base.kappa / 4, 1e-9 * base.kappa);
  EXPECT_NEAR(got.gamma_t, base.gamma_t / 4, 1e-9 * base.gamma_t);
  EXPECT_NEAR(got.gamma_r, base.gamma_r / 16, 1e-9 * base.gamma_r);
  EXPECT_NEAR(got.bend, base.bend / 16, 1e-9 * base.bend);
  EXPECT_NEAR(got.mass_per_length, 900 * kPi * r * r, 1e-12);
}

TEST(SceneParse, BoundaryKinds) {
  const Scene s =
      parse_scene(rod_scene(std::string(kMaterial) +
                            "    elements: 10\n    shape: {type: straight}\n"
                            "    boundary:\n"
                            "      - {clamp: start, kind: natural}\n"
                            "      - {clamp: end}\n"
                            "      - {node: 4, fix: true}\n"
                            "      - {node: 5, velocity: [0, 0, 0.1], start_time: 0.2}\n"
                            "      - {segment: 3, fix: true}\n"
                            "      - {segment: 6, spin_rate: 6.5, start_time: 0.1}\n"));
  const Rod& rod = s.world.rods()[0];
  Rod& r = const_cast<Rod&>(rod);
  ASSERT_NE(r.node_drive(0), nullptr);
  EXPECT_EQ(r.node_drive(0)->kind, NodeDrive::Kind::kFixed);
  ASSERT_NE(r.segment_drive(0), nullptr);
  EXPECT_EQ(r.segment_drive(0)->kind, SegmentDrive::Kind::kFixed);
  EXPECT_FALSE(rod.ghost_start().active);
  // Ghost clamp (the default): end node fixed, end segment free, ghost frame = its orientation.
  ASSERT_NE(r.node_drive(10), nullptr);
  EXPECT_EQ(r.segment_drive(9), nullptr);
  EXPECT_TRUE(rod.ghost_end().active);
  EXPECT_LT(rod.ghost_end().frame.angularDistance(rod.orientations()[9]), 1e-12);
  ASSERT_NE(r.node_drive(4), nullptr);
  EXPECT_EQ(r.node_drive(4)->kind, NodeDrive::Kind::kFixed);
  EXPECT_LT((r.node_drive(4)->origin - Vec3(0.4, 0, 0)).norm(), 1e-12);
  ASSERT_NE(r.node_drive(5), nullptr);
  EXPECT_EQ(r.node_drive(5)->kind, NodeDrive::Kind::kVelocity);
  EXPECT_EQ(r.node_drive(5)->velocity, Vec3(0, 0, 0.1));
  EXPECT_EQ(r.node_drive(5)->t_start, 0.2);
  ASSERT_NE(r.segment_drive(3), nullptr);
  EXPECT_EQ(r.segment_drive(3)->kind, SegmentDrive::Kind::kFixed);
  ASSERT_NE(r.segment_drive(6), nullptr);
  EXPECT_EQ(r.segment_drive(6)->kind, SegmentDrive::Kind::kSpin);
  EXPECT_EQ(r.segment_drive(6)->rate, 6.5);
  EXPECT_EQ(r.segment_drive(6)->t_start, 0.1);
  EXPECT_EQ(rod.node_drives().size(), 4u);
  EXPECT_EQ(rod.segment_drives().size(), 3u);
}

TEST(SceneParse, Loads) {
  const Scene s =
      parse_scene(rod_scene(std::string(kMaterial) +
                            "    elements: 10\n    shape: {type: straight}\n"
                            "    loads:\n"
                            "      - {node: end, force: [0, 0, -2], ramp_time: 0.5}\n"
                            "      - {segment: 2, torque: [0.1, 0, 0], start_time: 1}\n"));
  const auto& loads = s.world.rods()[0].loads();
  ASSERT_EQ(loads.size(), 2u);
  EXPECT_EQ(loads[0].kind, Load::Kind::kForce);
  EXPECT_EQ(loads[0].index, 10);
  EXPECT_EQ(loads[0].value, Vec3(0, 0, -2));
  EXPECT_EQ(loads[0].ramp_time, 0.5);
  EXPECT_EQ(loads[0].t_start, 0.0);
  EXPECT_EQ(loads[1].kind, Load::Kind::kTorque);
  EXPECT_EQ(loads[1].index, 2);
  EXPECT_EQ(loads[1].value, Vec3(0.1, 0, 0));
  EXPECT_EQ(loads[1].t_start, 1.0);
}

TEST(SceneParse, Grasps) {
  const Scene s = parse_scene(
      rod_scene(std::string(kMaterial) + "    elements: 10\n    shape: {type: straight}\n",
                "grasps:\n"
                "  - {name: a}\n"
                "  - {name: b, rod: r, place: node, value: 4, "
                "hold_orientation: false}\n"
                "  - {name: c, place: arc_length, value: 0.25}\n"
                "  - {name: d, place: start}\n"));
  ASSERT_EQ(s.grasps.size(), 4u);
  EXPECT_EQ(s.grasps[0].name, "a");
  EXPECT_EQ(s.grasps[0].rod, "r");  // the only rod
  EXPECT_EQ(s.grasps[0].place, GraspSpec::Place::kEnd);
  EXPECT_TRUE(s.grasps[0].hold_orientation);
  EXPECT_EQ(s.grasps[1].place, GraspSpec::Place::kNode);
  EXPECT_EQ(s.grasps[1].value, 4.0);
  EXPECT_FALSE(s.grasps[1].hold_orientation);
  EXPECT_EQ(s.grasps[2].place, GraspSpec::Place::kArcLength);
  EXPECT_EQ(s.grasps[2].value, 0.25);
  EXPECT_EQ(s.grasps[3].place, GraspSpec::Place::kStart);
}

TEST(SceneParse, TopLevelKeys) {
  const Scene s = parse_scene(
      "name: demo\ndescription: a test\ngravity: [0, 1, 0]\ntime_step: 2.0e-6\nintegrator: "
      "semi_implicit_euler\nduration: 0.5\nrods:\n  - {material: soft_cable, shape: {type: "
      "straight}}\n",
      {}, "/some/dir/file.yaml");
  EXPECT_EQ(s.name, "demo");
  EXPECT_EQ(s.description, "a test");
  EXPECT_EQ(s.source, "/some/dir/file.yaml");
  EXPECT_EQ(s.world.gravity, Vec3(0, 1, 0));
  EXPECT_EQ(s.world.time_step, 2e-6);
  EXPECT_EQ(s.duration, 0.5);
  EXPECT_EQ(s.world.integrator, Integrator::kSemiImplicitEuler);
  const std::string rods = "rods: [{material: soft_cable, shape: {type: straight}}]";
  EXPECT_EQ(parse_scene(rods, {}, "/x/my_scene.yaml").name, "my_scene");
  EXPECT_EQ(parse_scene(rods, {}, "s").world.integrator, Integrator::kSplitRotation);  // default
  EXPECT_EQ(parse_scene("integrator: split_rotation\n" + rods, {}, "s").world.integrator,
            Integrator::kSplitRotation);
}

TEST(SceneParse, Overrides) {
  const std::string base = rod_scene(std::string(kMaterial) +
                                     "    elements: 10\n    shape: {type: straight}\n"
                                     "    boundary:\n      - {clamp: start}\n");
  const Scene s = parse_scene(
      base, {"rods.0.elements=20", "time_step=2e-6", "gravity=[0,0,-1]", "rods.r.radius=0.02",
             "rods[0].shape.length=2", "rods.0.boundary.0.kind=natural",
             "rods.0.reference_d1=[0, 1, 0]", "duration=3"});
  const Rod& rod = s.world.rods()[0];
  EXPECT_EQ(rod.num_segments(), 20);
  EXPECT_EQ(s.world.time_step, 2e-6);
  EXPECT_EQ(s.world.gravity, Vec3(0, 0, -1));
  EXPECT_EQ(rod.section().radius, 0.02);
  EXPECT_NEAR(rod.length(), 2.0, 1e-12);
  EXPECT_FALSE(rod.ghost_start().active);
  EXPECT_EQ(rod.segment_drives().size(), 1u);
  EXPECT_LT((rod.orientations()[0].toRotationMatrix().col(0) - Vec3(0, 1, 0)).norm(), 1e-12);
  EXPECT_EQ(s.duration, 3.0);
  // A preset given by name can have its fields overridden.
  const Scene p = parse_scene("rods: [{material: soft_cable, shape: {type: straight}}]",
                              {"rods.0.material.damping_time=0.5"});
  EXPECT_DOUBLE_EQ(p.world.rods()[0].section().gamma_t, 0.5 * p.world.rods()[0].section().stretch);
}

TEST(SceneParse, WarnsAboveStabilityLimit) {
  const std::string base = rod_scene(std::string(kMaterial) + "    shape: {type: straight}\n");
  const Scene ok = parse_scene(base);
  EXPECT_TRUE(ok.warnings.empty());
  const double limit = critical_time_step(ok.world.rods()[0]);
  const Scene bad = parse_scene(base, {"time_step=" + std::to_string(1.5 * limit)});
  ASSERT_EQ(bad.warnings.size(), 1u);
  EXPECT_EQ(bad.warnings[0].rfind("time_step: ", 0), 0u) << bad.warnings[0];
  EXPECT_NE(bad.warnings[0].find("rod 'r'"), std::string::npos);
}

}  // namespace
}  // namespace corde

namespace corde {
namespace {

TEST(SceneParse, MaxStrainFromPresetOrKey) {
  const Scene a = parse_scene("rods:\n  - {material: soft_cable, shape: {type: straight}}\n");
  EXPECT_DOUBLE_EQ(a.world.rods()[0].section().max_strain, 0.02);
  const Scene b = parse_scene(
      "rods:\n  - {material: {preset: steel_wire, max_strain: 0.003}, shape: {type: straight}}\n");
  EXPECT_DOUBLE_EQ(b.world.rods()[0].section().max_strain, 0.003);
  EXPECT_THROW(parse_scene("rods:\n  - {material: {preset: steel_wire, max_strain: -1}, "
                           "shape: {type: straight}}\n"),
               SceneError);
}

}  // namespace
}  // namespace corde

namespace corde {
namespace {

TEST(SceneParse, DragCoefficientsOrFluid) {
  const std::string rod =
      "rods:\n  - {material: soft_cable, radius: 0.004, shape: {type: straight}, ";
  const Scene a = parse_scene(rod + "drag: {linear_normal: 0.5, quadratic_tangential: 0.01}}\n");
  EXPECT_DOUBLE_EQ(a.world.rods()[0].drag().linear_normal, 0.5);
  EXPECT_DOUBLE_EQ(a.world.rods()[0].drag().quadratic_tangential, 0.01);
  // Air at 1.2 kg/m^3 on a 4 mm cylinder: q_n = rho C_d r, q_t = rho C_f pi r.
  const Scene b =
      parse_scene(rod +
                  "drag: {fluid_density: 1.2, drag_coefficient: 1.1, friction_coefficient: "
                  "0.02}}\n");
  EXPECT_DOUBLE_EQ(b.world.rods()[0].drag().quadratic_normal, 1.2 * 1.1 * 0.004);
  EXPECT_DOUBLE_EQ(b.world.rods()[0].drag().quadratic_tangential, 1.2 * 0.02 * M_PI * 0.004);
  EXPECT_FALSE(parse_scene(rod + "}\n").world.rods()[0].drag().active());
  for (const char* bad :
       {"drag: {linear_normal: -1}}\n", "drag: {fluid_density: 1.2, quadratic_normal: 1}}\n",
        "drag: {drag_coefficient: 1}}\n", "drag: {speed: 1}}\n"}) {
    try {
      parse_scene(rod + bad);
      ADD_FAILURE() << "accepted " << bad;
    } catch (const SceneError& e) {
      EXPECT_NE(std::string(e.what()).find("rods[0].drag"), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace corde
