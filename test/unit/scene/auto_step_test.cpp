// time_step: auto for every method and integrator: auto: the implicit step's accuracy rule holds
// what it states (a mode loses at most 10% per period), drives bound it, and the automatic method
// is implicit for a steel cable and explicit for a soft rope at a coarse resolution.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "corde_sim/scene/automatic_choices.h"
#include "corde_sim/scene/scene.h"

namespace corde {
namespace {

// A cantilever (ghost clamp at the start) along x; `extra` holds top-level keys (gravity is off
// unless given there), `boundary` more boundary entries.
std::string cantilever(const std::string& material, double radius, int elements,
                       const std::string& extra = "", const std::string& boundary = "") {
  const bool gravity = extra.find("gravity") != std::string::npos;
  return std::string(gravity ? "" : "gravity: [0, 0, 0]\n") + "duration: 1.0\n" + extra +
         "rods:\n"
         "  - name: beam\n"
         "    elements: " +
         std::to_string(elements) + "\n    radius: " + std::to_string(radius) +
         "\n    material: " + material +
         "\n    shape: {type: straight, direction: [1, 0, 0], length: 1.0}\n"
         "    reference_d1: [0, 0, 1]\n"
         "    boundary:\n"
         "      - {clamp: start}\n" +
         boundary;
}

const char* kSteel = "{E: 2.0e11, nu: 0.27, rho: 7850}";

bool contains(const std::string& s, const std::string& what) {
  return s.find(what) != std::string::npos;
}

TEST(ImplicitTimeStep, SoftRopeTakesTheFrame) {
  const Scene s = parse_scene(cantilever("paper_rope", 0.01, 20));
  const ImplicitStepChoice step = implicit_time_step(s);
  EXPECT_DOUBLE_EQ(step.time_step, kFrameStep);
  EXPECT_TRUE(contains(step.why, "frame")) << step.why;
}

// A thick steel cantilever's first mode (1.875^2 sqrt(B / mu) / L^2 = 44 rad/s for r = 5 mm)
// sets the step; run at it, backward Euler keeps at least 90% of that mode's amplitude per period
// as the rule states, and at 5x the step it loses far more.
TEST(ImplicitTimeStep, LowestModeLosesAtMostTenPercentPerPeriod) {
  const double r = 0.005, B = 2.0e11 * M_PI * std::pow(r, 4) / 4.0, mu = 7850 * M_PI * r * r;
  const double omega = 1.875 * 1.875 * std::sqrt(B / mu);
  Scene s = parse_scene(cantilever(kSteel, r, 20, "integrator: implicit_euler\n"));
  const ImplicitStepChoice step = implicit_time_step(s);
  EXPECT_NEAR(step.time_step, 0.0335 / omega, 0.01 * step.time_step);
  EXPECT_TRUE(contains(step.why, "lowest mode")) << step.why;
  EXPECT_DOUBLE_EQ(s.world.time_step, step.time_step);  // time_step: auto took it
  // Amplitude after one period of the tip set swinging in its first mode's shape (velocity
  // proportional to (x/L)^2, a close stand-in), relative to the first swing.
  auto loss_per_period = [&](double h) {
    Scene run = parse_scene(cantilever(kSteel, r, 20, "integrator: implicit_euler\n"));
    run.world.time_step = h;
    Rod& rod = run.world.rods()[0];
    for (int i = 0; i < rod.num_nodes(); ++i) {
      const double x = static_cast<double>(i) / rod.num_segments();
      rod.velocities()[i] = Vec3(0, 0, 0.01 * x * x);
    }
    const double period = 2.0 * M_PI / omega;
    double first = 0.0, second = 0.0;
    for (double t = 0.0; t < 2.0 * period; t += h) {
      run.world.step();
      const double z = std::abs(rod.positions().back().z());
      (t < period ? first : second) = std::max(t < period ? first : second, z);
    }
    return 1.0 - second / first;
  };
  const double at_step = loss_per_period(step.time_step);
  EXPECT_LT(at_step, 0.12);  // 10% by the rule, with the stand-in's higher modes
  EXPECT_GT(loss_per_period(5.0 * step.time_step), 2.0 * at_step);
}

TEST(ImplicitTimeStep, DrivesBoundIt) {
  // A node driven at 5 m/s on 0.05 m elements: half an element per step is 5 ms; at 50 m/s 0.5 ms.
  const Scene s = parse_scene(cantilever("paper_rope", 0.01, 20, "") +
                              "      - {node: end, velocity: [0, 0, 50]}\n");
  const ImplicitStepChoice step = implicit_time_step(s);
  EXPECT_NEAR(step.time_step, 0.5 * 0.05 / 50.0, 1e-9);
  EXPECT_TRUE(contains(step.why, "node 20")) << step.why;
  const Scene spin = parse_scene(
      "rods:\n  - {name: r, material: paper_rope, elements: 10, shape: {type: straight},\n"
      "     boundary: [{clamp: start, kind: natural}, {segment: end, spin_rate: 200}]}\n");
  EXPECT_NEAR(implicit_time_step(spin).time_step, 0.1 / 200.0, 1e-12);
}

// A grasp sets the lowest mode (a free beam's 4.730^2 against a clamped one's 1.875^2, 6.4x) only
// when it holds for the whole run: a late or released grasp leaves the beam free for a while.
TEST(ImplicitTimeStep, OnlyAWholeRunGraspHoldsTheRod) {
  auto step = [](const std::string& grasp_keys) {
    const Scene s = parse_scene(
        "gravity: [0, 0, 0]\nduration: 1.0\nintegrator: implicit_euler\n"
        "rods:\n  - {name: beam, elements: 20, radius: 0.005, material: " +
        std::string(kSteel) +
        ",\n     shape: {type: straight, direction: [1, 0, 0], length: 1.0}}\n"
        "grasps:\n  - {name: g, rod: beam, place: start" +
        grasp_keys + "}\n");
    return implicit_time_step(s).time_step;
  };
  const double r = 0.005, B = 2.0e11 * M_PI * std::pow(r, 4) / 4.0, mu = 7850 * M_PI * r * r;
  const double free_step = 0.0335 / (4.730 * 4.730 * std::sqrt(B / mu));
  EXPECT_NEAR(step(""), 0.0335 / (1.875 * 1.875 * std::sqrt(B / mu)), 1e-3 * free_step);
  EXPECT_NEAR(step(", grasp_time: 0.5"), free_step, 1e-3 * free_step);
  EXPECT_NEAR(step(", release_time: 0.5"), free_step, 1e-3 * free_step);
}

// A 1 m steel cable of r = 1 mm at 40 elements: the explicit step is microseconds, the implicit
// one the 2 ms frame; the measured costs make implicit the choice by far.
TEST(AutoIntegrator, SteelCableIsImplicit) {
  const Scene s = parse_scene(cantilever(kSteel, 0.001, 40,
                                         "integrator: auto\n"
                                         "gravity: [0, 0, -9.81]\n"));
  EXPECT_EQ(s.world.integrator, Integrator::kImplicitEuler);
  EXPECT_DOUBLE_EQ(s.world.time_step, kFrameStep);
  ASSERT_FALSE(s.notes.empty());
  EXPECT_TRUE(contains(s.notes.back(), "integrator: auto chose implicit_euler")) << s.notes.back();
}

// paper_rope (E 0.5 MPa) at 10 elements: stable explicitly at 0.1 ms steps of a fraction of a
// microsecond each; the implicit step costs more than the 20 explicit steps that replace it.
TEST(AutoIntegrator, SoftRopeAtACoarseResolutionIsExplicit) {
  const Scene s = parse_scene(cantilever("{preset: paper_rope, damping_time: 0}", 0.01, 10,
                                         "integrator: auto\ngravity: [0, 0, -9.81]\n"));
  EXPECT_EQ(s.world.integrator, kDefaultIntegrator);
  ASSERT_FALSE(s.notes.empty());
  EXPECT_TRUE(contains(s.notes.back(), "integrator: auto chose split_rotation")) << s.notes.back();
}

TEST(AutoIntegrator, GivenStepDecidesWithoutATrial) {
  const Scene steel =
      parse_scene(cantilever(kSteel, 0.001, 40, "integrator: auto\ntime_step: 0.001\n"));
  EXPECT_EQ(steel.world.integrator, Integrator::kImplicitEuler);
  EXPECT_DOUBLE_EQ(steel.world.time_step, 0.001);
  EXPECT_TRUE(steel.warnings.empty());  // no stability warning for the implicit method
  const Scene rope =
      parse_scene(cantilever("paper_rope", 0.01, 10, "integrator: auto\ntime_step: 1.0e-5\n"));
  EXPECT_EQ(rope.world.integrator, kDefaultIntegrator);
}

TEST(AutoIntegrator, UnknownNameIsRefusedWithTheList) {
  try {
    parse_scene(cantilever("paper_rope", 0.01, 10, "integrator: rk4\n"));
    ADD_FAILURE() << "no error";
  } catch (const SceneError& e) {
    EXPECT_TRUE(contains(e.what(), "integrator")) << e.what();
    EXPECT_TRUE(contains(e.what(), "implicit_euler")) << e.what();
    EXPECT_TRUE(contains(e.what(), "auto")) << e.what();
  }
}

TEST(AutoTimeStep, ExplicitMethodsKeepTheirStabilityRule) {
  const Scene s = parse_scene(cantilever("paper_rope", 0.01, 10, "integrator: split_rotation\n"));
  std::string why;
  EXPECT_DOUBLE_EQ(s.world.time_step, explicit_time_step(s.world, &why));
  EXPECT_TRUE(contains(why, "stability limit")) << why;
}

}  // namespace
}  // namespace corde
