// The implicit integrator run by World::step: consistency with the explicit method (first order
// convergence of the difference as h shrinks, with internal friction, drag, follower loads, line,
// plane and hinge constraints all acting), rigid motion left alone by internal friction, and
// contacts (non-penetration, Coulomb friction) at steps far beyond the explicit limit.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "corde_sim/scene/scene.h"
#include "corde_sim/stability/explicit_step_limit.h"
#include "dynamics_util.h"

namespace corde {
namespace {

using dyn::kPi;

// A soft rod clamped at its start with everything the implicit step must treat: internal
// friction, drag, gravity, a follower force and torque at the tip, a node sliding in a plane, a
// node on a line and a hinged segment.
Scene loaded_rod(const std::string& integrator, double h) {
  char buf[1600];
  std::snprintf(
      buf, sizeof buf,
      "gravity: [0, 0, -9.81]\ntime_step: %.17g\nintegrator: %s\n"
      "rods:\n  - name: rod\n    elements: 12\n    radius: 0.005\n"
      "    material: {E: 2.0e6, nu: 0.5, rho: 1000, damping_time: 2.0e-3}\n"
      "    drag: {linear_normal: 0.5, quadratic_normal: 2.0, linear_tangential: 0.1}\n"
      "    shape: {type: straight, start: [0, 0, 0], direction: [1, 0, 0.3], length: 0.3}\n"
      "    boundary:\n      - {clamp: start}\n      - {node: 6, plane: [0, 1, 0.2]}\n"
      "      - {node: 9, line: [0.2, 0.1, 1]}\n      - {segment: 11, free_axis: tangent}\n"
      "    loads:\n      - {node: 12, force: [0.01, 0, -0.02], kind: follower}\n"
      "      - {segment: 11, torque: [0, 0, 2.0e-4], kind: follower}\n"
      "      - {segment: 3, torque: [1.0e-4, 0, 0]}\n",
      h, integrator.c_str());
  return parse_scene(buf);
}

double max_speed(const Rod& rod) {
  double v = 0.0;
  for (const Vec3& u : rod.velocities()) v = std::max(v, u.norm());
  return v;
}

double max_node_distance(const Rod& a, const Rod& b) {
  double d = 0.0;
  for (int i = 0; i < a.num_nodes(); ++i)
    d = std::max(d, (a.positions()[i] - b.positions()[i]).norm());
  return d;
}

// Both methods approximate the same equations: at shrinking steps the implicit result approaches
// a fine explicit reference at first order. A missing or mis-signed term (friction, drag, a
// follower load, a constraint's projection) would leave a difference that does not shrink.
TEST(ImplicitWorld, ConvergesToTheExplicitSolutionAtFirstOrder) {
  const double duration = 0.2;
  Scene ref = loaded_rod("split_rotation", 1e-6);
  const double hc = critical_time_step(ref.world.rods()[0]);
  ref.world.time_step = std::min(1e-6, 0.5 * hc);
  ref.world.step(static_cast<int>(std::lround(duration / ref.world.time_step)));
  ASSERT_TRUE(ref.world.finite());
  std::vector<double> err;
  for (double h : {4e-4, 2e-4, 1e-4}) {
    Scene s = loaded_rod("implicit_euler", h);
    s.world.step(static_cast<int>(std::lround(duration / h)));
    ASSERT_TRUE(s.world.finite());
    EXPECT_EQ(s.world.implicit_stats().unconverged, 0) << h;
    err.push_back(max_node_distance(s.world.rods()[0], ref.world.rods()[0]));
    std::printf("h = %g: max node difference %.3e m\n", h, err.back());
    const Rod& rod = s.world.rods()[0];
    // Constraints hold exactly.
    EXPECT_NEAR((rod.positions()[6] - ref.world.rods()[0].positions()[6]).dot(Vec3(0, 1, 0.2)), 0.0,
                1e-12);
  }
  // The rod moved by several cm; the difference is a fraction of that and halves with h.
  const double moved = (ref.world.rods()[0].positions()[12] -
                        loaded_rod("split_rotation", 1e-6).world.rods()[0].positions()[12])
                           .norm();
  EXPECT_GT(moved, 0.005);
  EXPECT_LT(err[0], 0.1 * moved);
  for (size_t k = 1; k < err.size(); ++k) {
    const double order = std::log2(err[k - 1] / err[k]);
    EXPECT_GT(order, 0.8) << "h = " << 4e-4 / (1 << k);
    EXPECT_LT(order, 1.3) << "h = " << 4e-4 / (1 << k);
  }
}

// Internal friction damps strain rates only: a free rod moving rigidly (translation and a spin
// about its axis, no gravity) keeps its momentum; its centre of mass moves uniformly.
TEST(ImplicitWorld, InternalFrictionLeavesRigidTranslationAlone) {
  Scene s = parse_scene(
      "gravity: [0, 0, 0]\ntime_step: 2.0e-3\nintegrator: implicit_euler\n"
      "rods:\n  - {name: rod, elements: 20, radius: 0.005, material: {E: 2.0e11, nu: 0.3, rho: "
      "7850, damping_time: 1.0e-2}, shape: {type: straight, start: [0, 0, 0], direction: [1, 0, "
      "0], length: 1.0}, initial: {velocity: [0.3, -0.2, 0.1]}}\n");
  Rod& rod = s.world.rods()[0];
  const Vec3 p0 = rod.linear_momentum(), c0 = rod.center_of_mass();
  s.world.step(500);  // 1 s
  EXPECT_LT((rod.linear_momentum() - p0).norm(), 1e-12 * p0.norm());
  EXPECT_LT((rod.center_of_mass() - c0 - Vec3(0.3, -0.2, 0.1)).norm(), 1e-10);
}

// A steel cable dropped onto a floor at h = 1 ms (hundreds of times the explicit limit) lands
// and rests on it. The contact rounds (ContactSettings::implicit_rounds) leave the landing ends
// sinking in by about 1% of the radius (measured 1.05% at 30 rounds, 0.86% at 100); bound 2%.
// At rest it stays below 1e-3 of the radius.
TEST(ImplicitWorld, SteelCableLandsOnAFloorAtMillisecondSteps) {
  Scene s = parse_scene(
      "gravity: [0, 0, -9.81]\ntime_step: 1.0e-3\nintegrator: implicit_euler\n"
      "obstacles:\n  - {name: floor, type: plane, normal: [0, 0, 1], friction: 0.4}\n"
      "rods:\n  - {name: cable, elements: 40, radius: 0.002, material: {preset: steel_wire}, "
      "shape: {type: straight, start: [0, 0, 0.1], direction: [1, 0, 0.2], length: 1.0}}\n");
  const Rod& rod = s.world.rods()[0];
  EXPECT_GT(1e-3, 100.0 * critical_time_step(rod));
  double deepest = 0.0;
  for (int k = 0; k < 1500; ++k) {
    s.world.step();
    ASSERT_TRUE(s.world.finite());
    for (const Vec3& x : rod.positions()) deepest = std::max(deepest, 0.002 - x.z());
  }
  EXPECT_LT(deepest, 0.02 * 0.002);
  EXPECT_LT(s.world.contacts()->stats().max_penetration, 1e-3 * 0.002);
  // At rest on the floor.
  for (const Vec3& x : rod.positions()) EXPECT_NEAR(x.z(), 0.002, 0.02 * 0.002);
  EXPECT_LT(max_speed(rod), 1e-3);
}

// Coulomb friction with the implicit step at 1 ms: a rope on a plane tilted by 20 degrees with
// mu = 0.5 stays put; at 30 degrees with mu = 0.3 it slides with g (sin - mu cos) within 2%.
std::string rope_on_slope(double tilt_deg, double mu) {
  const double a = tilt_deg * kPi / 180.0, r = 0.005;
  const Vec3 down(std::cos(a), 0.0, -std::sin(a)), n(std::sin(a), 0.0, std::cos(a));
  char buf[1200];
  std::snprintf(buf, sizeof buf,
                "gravity: [0, 0, -9.81]\ntime_step: 1.0e-3\nintegrator: implicit_euler\n"
                "obstacles:\n  - {name: slope, type: plane, normal: [%.17g, 0, %.17g], friction: "
                "%.17g}\n"
                "rods:\n  - name: rope\n    elements: 20\n    radius: %g\n"
                "    material: {E: 1.0e6, nu: 0.5, rho: 1000, damping_time: 1.0e-3}\n"
                "    shape: {type: straight, start: [%.17g, 0, %.17g], direction: [%.17g, 0, "
                "%.17g], length: 0.5}\n",
                n.x(), n.z(), mu, r, r * n.x(), r * n.z(), down.x(), down.z());
  return buf;
}

Vec3 mean_velocity_of(const Rod& rod) {
  Vec3 v = Vec3::Zero();
  for (const Vec3& u : rod.velocities()) v += u;
  return v / rod.num_nodes();
}

TEST(ImplicitWorld, RopeOnTiltedPlaneSticksOrSlides) {
  {
    Scene s = parse_scene(rope_on_slope(20.0, 0.5));
    s.world.step(500);
    const Vec3 x0 = s.world.rods()[0].center_of_mass();
    s.world.step(500);
    const double a = 20.0 * kPi / 180.0;
    const Vec3 down(std::cos(a), 0.0, -std::sin(a));
    EXPECT_LT(std::abs((s.world.rods()[0].center_of_mass() - x0).dot(down)), 1e-5);
    EXPECT_LT(mean_velocity_of(s.world.rods()[0]).norm(), 1e-4);
  }
  const double mu = 0.3, a = 30.0 * kPi / 180.0;
  Scene s = parse_scene(rope_on_slope(30.0, mu));
  s.world.step(250);
  const Vec3 v0 = mean_velocity_of(s.world.rods()[0]);
  s.world.step(500);
  const Vec3 v1 = mean_velocity_of(s.world.rods()[0]);
  const double accel = (v1 - v0).norm() / 0.5;
  const double want = 9.81 * (std::sin(a) - mu * std::cos(a));
  EXPECT_NEAR(accel, want, 0.02 * want);
  EXPECT_LT(s.world.contacts()->stats().max_penetration, 0.01 * 0.005);
}

// The sweeps of a round answer with node masses alone and the rods' true response corrects them, so
// few sweeps a round (ContactSettings::implicit_sweeps) change the cost, not the result: a coiled
// rope that has set (rest_shape: created), its end lying across its start, dropped from 10 cm onto
// a floor (self contact on), as it lands and settles, with 2 sweeps a round and with 30 (the
// former setting). Its contacts hold to the same depth and it lies in the same place to a small
// fraction of its radius, with a ninth of the sweeps. The key is read from the scene and checked.
Scene dropped_coil(int sweeps) {
  std::string y =
      "time_step: 2.0e-3\nintegrator: implicit_euler\n"
      "obstacles:\n  - {name: floor, type: plane, normal: [0, 0, 1], friction: 0.5}\n"
      "contact: {friction: 0.4, implicit_sweeps: " +
      std::to_string(sweeps) +
      "}\n"
      "rods:\n  - name: rope\n    elements: 60\n    radius: 0.005\n"
      "    material: {preset: nylon_rope, E: 1.0e7, E_s: 1.0e7}\n"
      "    contact: {self: true}\n    rest_shape: created\n"
      "    shape:\n      type: polyline\n      points:\n";
  // 1.15 turns of radius 0.1 m rising 1.2 cm a turn.
  const double radius = 0.1, turns = 1.15;
  for (int i = 0; i <= 200; ++i) {
    const double a = 2.0 * kPi * turns * i / 200.0;
    char p[96];
    std::snprintf(p, sizeof p, "        - [%.9f, %.9f, %.9f]\n", radius * std::cos(a),
                  radius * std::sin(a), 0.1 + 0.012 * a / (2.0 * kPi));
    y += p;
  }
  Scene scene = parse_scene(y);
  EXPECT_EQ(scene.world.contact.implicit_sweeps, sweeps);
  return scene;
}

TEST(ImplicitWorld, FewSweepsARoundGiveTheSameRest) {
  Scene few = dropped_coil(2), many = dropped_coil(30);
  double deepest[2] = {0.0, 0.0};
  long sweeps[2] = {0, 0};
  for (int k = 0; k < 500; ++k) {  // 1 s: the fall (about 0.14 s), landing and settling
    few.world.step(1);
    many.world.step(1);
    deepest[0] = std::max(deepest[0], few.world.contacts()->stats().max_penetration);
    deepest[1] = std::max(deepest[1], many.world.contacts()->stats().max_penetration);
    sweeps[0] += few.world.contacts()->stats().iterations;
    sweeps[1] += many.world.contacts()->stats().iterations;
  }
  const double r = 0.005;
  // At the impact (1.4 m/s, h = 2 ms) the overlap found at a step's start reaches about 3 % of
  // the radius either way (measured 3.3 % and 2.9 %), then is pushed out.
  EXPECT_LT(deepest[0], 0.05 * r);
  EXPECT_LT(deepest[1], 0.05 * r);
  EXPECT_LT(std::abs(deepest[0] - deepest[1]), 0.01 * r);
  const auto& a = few.world.rods()[0].positions();
  const auto& b = many.world.rods()[0].positions();
  double apart = 0.0;
  for (size_t i = 0; i < a.size(); ++i) apart = std::max(apart, (a[i] - b[i]).norm());
  EXPECT_LT(apart, 0.15 * r);  // measured 0.067 r
  EXPECT_LT(mean_velocity_of(few.world.rods()[0]).norm(), 1e-2);
  EXPECT_LT(2 * sweeps[0], sweeps[1]);  // the sweeps saved
  std::printf("sweeps %ld against %ld; deepest %.3g and %.3g of r; apart %.3g of r\n", sweeps[0],
              sweeps[1], deepest[0] / r, deepest[1] / r, apart / r);
  // Out of range: refused with the key's path.
  try {
    parse_scene(
        "rods:\n  - {name: r, material: {preset: nylon_rope}, shape: {type: straight}}\n"
        "contact: {implicit_sweeps: 0}\n");
    ADD_FAILURE() << "implicit_sweeps: 0 accepted";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("contact.implicit_sweeps"), std::string::npos) << e.what();
  }
}

// A rope of 100 elements (r = 5 mm) coiled into a tight flat spiral on a floor, its rest shape
// straight, self contact on: it springs open on itself once released.
Scene spiral_on_floor() {
  const double r = 0.005, pitch = 2.0 * r + 1e-4, a = 0.03, length = 1.0;
  std::string y =
      "time_step: auto\n"
      "obstacles:\n  - {name: floor, type: plane, normal: [0, 0, 1], friction: 0.5}\n"
      "contact: {friction: 0.4}\n"
      "rods:\n  - name: rope\n    elements: 100\n    radius: 0.005\n"
      "    material: {preset: nylon_rope, E: 1.0e7, E_s: 1.0e7}\n    contact: {self: true}\n"
      "    shape:\n      type: polyline\n      points:\n";
  // Points 2 mm apart along the spiral of radius a + pitch theta / (2 pi), lying on the floor.
  double theta = 0.0, s = 0.0;
  Vec3 prev(a, 0.0, r);
  char line[128];
  while (true) {
    std::snprintf(line, sizeof line, "        - [%.9g, %.9g, %.9g]\n", prev.x(), prev.y(), r);
    y += line;
    if (s >= length) break;
    theta += 0.002 / (a + pitch * theta / (2.0 * kPi));
    const double rad = a + pitch * theta / (2.0 * kPi);
    const Vec3 p(rad * std::cos(theta), rad * std::sin(theta), r);
    s += (p - prev).norm();
    prev = p;
  }
  return parse_scene(y);
}

// The contact response may use the last Newton iteration's exact-Hessian factorisation only while
// its answer stays within the bound a definite matrix (A >= M / h^2) guarantees. A rope of 100
// elements coiled into a tight flat spiral with a straight rest shape springs open on itself at
// up to 7 m/s with hundreds of contacts; answered on an unbounded exact matrix it was thrown
// 1e12 radii deep into the floor (0.105 r with the bound). It must stay finite, its overlaps
// bounded.
TEST(ImplicitWorld, ContactResponseOnTheExactMatrixStaysBounded) {
  const double r = 0.005;
  Scene scene = spiral_on_floor();
  World& w = scene.world;
  w.step(100);  // explicit, about 3 ms: contacts found and warm started, the spiral opening
  w.integrator = Integrator::kImplicitEuler;
  w.time_step = 2e-3;
  double deepest = 0.0;
  for (int k = 0; k < 60; ++k) {
    w.step();
    ASSERT_TRUE(w.finite()) << "step " << k;
    deepest = std::max(deepest, w.contacts()->stats().max_penetration);
  }
  std::printf("deepest overlap %.3g r in 0.12 s\n", deepest / r);
  EXPECT_LT(deepest, 0.25 * r);
}

// Once the spiral has sprung open and lies still (after 3 s at h = 2 ms; it still slid at 2 s
// once redetection within a step kept the passes' relinearised contacts), the contact rounds leave
// its impulses to about 1e-4 of the largest from step to step. The step's Newton tolerance stops
// at that noise (ImplicitOptions::prediction_tolerance = 1e-5), so many steps take no Newton
// iteration (128 of these 200); at 1e-6 every step took one (0 of 200 without), and a probe of
// the same rope from 2 to 4 s counted a fifth more instructions (callgrind). The rope stays where
// it lies (moved 0.15 nm).
TEST(ImplicitWorld, RopeLyingStillSkipsNewtonAtManySteps) {
  Scene scene = spiral_on_floor();
  World& w = scene.world;
  w.integrator = Integrator::kImplicitEuler;
  w.time_step = 2e-3;
  w.step(1500);
  ASSERT_TRUE(w.finite());
  const std::vector<Vec3> start = w.rods()[0].positions();
  int none = 0;
  const int steps = 200;
  for (int k = 0; k < steps; ++k) {
    w.step();
    if (w.implicit_stats().iterations == 0) ++none;
  }
  double moved = 0.0;
  for (size_t i = 0; i < start.size(); ++i)
    moved = std::max(moved, (w.rods()[0].positions()[i] - start[i]).norm());
  std::printf("%d of %d steps without a Newton iteration; largest move %.3g m in 0.4 s\n", none,
              steps, moved);
  EXPECT_GE(none, steps / 5);
  EXPECT_LT(moved, 1e-4);  // a fiftieth of the radius
}

}  // namespace
}  // namespace corde
