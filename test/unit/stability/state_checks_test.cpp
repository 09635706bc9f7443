// The state checks (stability/state_checks.h) that the guard, the node (through the guard) and
// corde_run's runaway stop share: a state that breaks each one is caught with the message
// docs/stability_guard.md gives, and the guard reports it as its event.
#include "corde_sim/stability/state_checks.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "corde_sim/scene/scene.h"
#include "corde_sim/stability/step_guard.h"

namespace corde {
namespace {

// A 0.5 m rod of 20 elements along x, clamped at its start (r = 1 cm, E = 1e7 Pa).
World beam() {
  return parse_scene(R"(
gravity: [0, 0, -9.81]
time_step: 1e-5
rods:
  - name: cable
    elements: 20
    radius: 0.01
    material: {E: 1e7, G: 3.3e6, rho: 1000}
    shape: {type: straight, start: [0, 0, 1], direction: [1, 0, 0], length: 0.5}
    boundary:
      - {clamp: start, kind: ghost}
)")
      .world;
}

std::string message(const World& w, const StateLimits& limits = StateLimits()) {
  return check_state(w, limits).message();
}

TEST(StateChecks, AGoodStatePassesEveryCheck) {
  StateLimits all;
  all.max_shear_angle = 0.8;
  all.max_bend_angle = 1.6;
  all.max_specific_energy = 1e5;
  EXPECT_FALSE(check_state(beam(), all).found);
  EXPECT_EQ(message(beam(), all), "");
}

TEST(StateChecks, NonFinite) {
  World n = beam();
  n.rods()[0].positions()[3].x() = NAN;
  EXPECT_EQ(message(n), "rod 'cable': node 3 is not finite");
  EXPECT_EQ(check_state(n, StateLimits()).check, StateCheck::kNonFinite);
  World s = beam();
  s.rods()[0].angular_velocities()[1].y() = INFINITY;
  EXPECT_EQ(message(s), "rod 'cable': segment 1 is not finite");
}

TEST(StateChecks, QuaternionOffUnitNorm) {
  World z = beam();
  z.rods()[0].orientations()[2].coeffs().setZero();  // what a blow-up can leave behind
  EXPECT_EQ(message(z), "rod 'cable': segment 2 has a quaternion of norm 0 (tolerance 1e-06)");
  World q = beam();
  q.rods()[0].orientations()[2].coeffs() *= 1.01;
  const StateProblem p = check_state(q, StateLimits());
  EXPECT_EQ(p.check, StateCheck::kQuaternion);
  EXPECT_EQ(p.item, 2);
  EXPECT_EQ(p.message(), "rod 'cable': segment 2 has a quaternion of norm 1.01 (tolerance 1e-06)");
  q.rods()[0].orientations()[2].coeffs() /= 1.01 * (1.0 + 5e-7);  // within the tolerance
  EXPECT_FALSE(check_state(q, StateLimits()).found);
}

TEST(StateChecks, Speeds) {
  World v = beam();
  v.rods()[0].velocities()[0] = Vec3(150, 0, 0);
  EXPECT_EQ(message(v), "rod 'cable': node 0 moves at 150 m/s (limit 100)");
  EXPECT_EQ(check_state(v, StateLimits()).check, StateCheck::kSpeed);
  v.rods()[0].velocities()[0] = Vec3(50, 0, 0);
  EXPECT_FALSE(check_state(v, StateLimits()).found);
  World s = beam();
  s.rods()[0].angular_velocities()[1] = Vec3(0, 0, 1e20);
  EXPECT_EQ(message(s), "rod 'cable': segment 1 spins at 1e+20 rad/s (limit 1e+05)");
}

TEST(StateChecks, StretchAndCompression) {
  World w = beam();
  w.rods()[0].positions()[20].x() += 0.025 * 3.5;  // the last segment stretched by 3.5
  const StateProblem p = check_state(w, StateLimits());
  EXPECT_EQ(p.check, StateCheck::kStretch);
  EXPECT_EQ(p.item, 19);
  EXPECT_EQ(p.message(), "rod 'cable': segment 19 stretched by 3.5 (limit 3)");
  World c = beam();
  c.rods()[0].positions()[20].x() -= 0.025 * 0.95;  // compressed to 5 % of its length
  EXPECT_EQ(message(c), "rod 'cable': segment 19 compressed by 0.95 (limit 0.9)");
  // corde_run's runaway limits: |axial strain| 10, so neither is caught there.
  EXPECT_FALSE(check_state(w, runaway_state_limits()).found);
  EXPECT_FALSE(check_state(c, runaway_state_limits()).found);
}

TEST(StateChecks, ShearIsOffByDefault) {
  World w = beam();
  w.rods()[0].positions()[6].z() -= 0.025;  // segments 5 and 6 turned 45 degrees off d3
  EXPECT_FALSE(check_state(w, StateLimits()).found);
  StateLimits on;
  on.max_shear_angle = 0.7;
  const StateProblem p = check_state(w, on);
  EXPECT_EQ(p.check, StateCheck::kShear);
  EXPECT_EQ(p.message(), "rod 'cable': segment 5 frame 0.785 rad off its tangent (limit 0.7)");
}

TEST(StateChecks, BendIsOffByDefault) {
  World w = beam();
  Quat& q = w.rods()[0].orientations()[8];
  q = Quat(Eigen::AngleAxisd(2.0, Vec3::UnitX())) * q;  // twisted by 2 rad about its tangent
  EXPECT_FALSE(check_state(w, StateLimits()).found);
  StateLimits on;
  on.max_bend_angle = 1.6;
  const StateProblem p = check_state(w, on);
  EXPECT_EQ(p.check, StateCheck::kBend);
  EXPECT_EQ(p.message(), "rod 'cable': element 7 turned 2 rad from its rest shape (limit 1.6)");
}

TEST(StateChecks, SpecificEnergyInCordeRunsLimitsOnly) {
  World w = beam();
  for (Vec3& v : w.rods()[0].velocities()) v = Vec3(0, 0, 500);  // 1.25e5 J/kg
  StateLimits limits = runaway_state_limits();
  limits.max_speed = 0.0;  // off: the energy check alone
  EXPECT_EQ(message(w, limits),
            "rod 'cable': 1.25e+05 J/kg of kinetic + elastic energy (limit 1e+05)");
  StateLimits guard;
  guard.max_speed = 0.0;
  EXPECT_FALSE(check_state(w, guard).found);  // the guard bounds energy growth instead
}

// The guard (which the node runs every step through) reports a check's failure as its event,
// with the same text, and recovers from it.
TEST(StateChecks, TheGuardReportsTheCheckItFailed) {
  World w = beam();
  StepGuard guard;
  guard.reset(w);
  // Corrupted in the last step before the check (every 64 steps): the next step would
  // renormalise it.
  int steps = 0;
  const StepGuard::StepFn corrupt_once = [&](World* world) {
    world->step();
    if (++steps == guard.settings().check_every)
      world->rods()[0].orientations()[2].coeffs() *= 1.01;
  };
  ASSERT_TRUE(guard.step(&w, 100, corrupt_once));
  ASSERT_FALSE(guard.events().empty());
  const GuardEvent& e = guard.events().front();
  EXPECT_EQ(e.kind, GuardEvent::Kind::kQuaternion);
  EXPECT_EQ(e.action, GuardEvent::Action::kHalveStep);
  EXPECT_NE(e.message().find(
                "quaternion, rod 'cable': segment 2 has a quaternion of norm 1.01 (tolerance "
                "1e-06); rolled back to t = 0 s, retrying with half the step"),
            std::string::npos)
      << e.message();
  EXPECT_FALSE(check_state(w, StateLimits()).found);
}

}  // namespace
}  // namespace corde
