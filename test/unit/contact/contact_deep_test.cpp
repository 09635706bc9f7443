// Deep contacts: a fast impact with bdf2 stays as shallow as with implicit_euler; the stability
// guard does not keep a state grossly inside a static obstacle; a cable pinched between two
// moving plates (closing to less than its diameter, then one jumping sideways) is pushed out at a
// bounded speed, never launched, and the deep contact is reported with the obstacles' names.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <utility>
#include <vector>

#include "corde_sim/contact/contact.h"
#include "corde_sim/scene/scene.h"
#include "corde_sim/scene/scene_runner.h"
#include "corde_sim/stability/step_guard.h"
#include "corde_sim/world/world.h"
#include "overlap_util.h"

namespace corde {
namespace {

using testing_overlap::measure_overlap;

// A 0.6 m rope (r = 5 mm) thrown flat at 44 m/s onto a plate 2 mm thick whose top is at z = 1 mm.
Scene plate_scene(const std::string& integrator) {
  return parse_scene(
      "time_step: 0.002\n"
      "integrator: " +
      integrator +
      "\n"
      "gravity: [0, 0, -9.81]\n"
      "obstacles:\n"
      "  - {name: plate, type: box, size: [1.0, 1.0, 0.002], position: [0, 0, 0]}\n"
      "rods:\n"
      "  - name: rope\n"
      "    elements: 40\n"
      "    radius: 0.005\n"
      "    material: nylon_rope\n"
      "    shape: {type: straight, start: [-0.3, 0, 0.1], direction: [1, 0, 0], length: 0.6}\n"
      "    initial: {velocity: [0, 0, -44]}\n");
}

struct ImpactResult {
  double deepest = 0.0;  // the deepest overlap with the plate over the run (m)
  double lowest = 1.0;   // the lowest node (m)
};

ImpactResult run_impact(const std::string& integrator) {
  Scene s = plate_scene(integrator);
  ImpactResult out;
  for (int k = 0; k < 25; ++k) {
    s.world.step();
    out.deepest = std::max(out.deepest, measure_overlap(s.world).obstacle);
    for (const Vec3& x : s.world.rods()[0].positions()) out.lowest = std::min(out.lowest, x.z());
  }
  return out;
}

// Before the fix bdf2's first step into the plate moved the rope by a third of its last step
// (29 mm) whatever the contact's impulse: it went through the plate (lowest node -0.17 m).
TEST(ContactDeep, Bdf2ImpactStaysShallowAsImplicitEuler) {
  const double r = 0.005;
  const ImpactResult be = run_impact("implicit_euler");
  const ImpactResult bdf2 = run_impact("bdf2");
  EXPECT_LT(be.deepest, 0.05 * r);
  EXPECT_LT(bdf2.deepest, 0.05 * r);
  EXPECT_GT(bdf2.lowest, 0.001 + 0.9 * r);  // on the plate, not through it
  EXPECT_NEAR(bdf2.lowest, be.lowest, 0.05 * r);
}

// A rod straight through a static box: the contact stage reports the penetration and the guard's
// state check refuses it, naming the rod and the obstacle. The same rod inside a moving obstacle
// is not the integrator's fault (a link can pinch a cable): no guard problem, but reported.
Scene inside_box(bool moving) {
  // The loader refuses a rod that starts inside an obstacle: load it 0.2 m above the box, then
  // move it in.
  Scene s = parse_scene(
      std::string("time_step: 1.0e-4\n"
                  "integrator: implicit_euler\n"
                  "obstacles:\n"
                  "  - {name: block, type: box, size: [0.1, 0.1, 0.1], position: [0.5, 0, "
                  "0.04], moving: ") +
      (moving ? "true" : "false") +
      "}\n"
      "rods:\n"
      "  - name: cable\n"
      "    elements: 20\n"
      "    radius: 0.003\n"
      "    material: soft_cable\n"
      "    shape: {type: straight, start: [0, 0, 0.2], direction: [1, 0, 0], length: "
      "1.0}\n");
  for (Vec3& x : s.world.rods()[0].positions()) x.z() -= 0.2;
  return s;
}

TEST(ContactDeep, GuardRefusesGrossPenetrationOfStaticObstacle) {
  Scene s = inside_box(false);
  s.world.step();
  ASSERT_NE(s.world.contacts(), nullptr);
  const ContactStats& st = s.world.contacts()->stats();
  EXPECT_NEAR(st.max_penetration, 0.013, 1e-3);  // axis 1 cm below the top face, r = 3 mm
  const StateProblem p = check_state(s.world, GuardSettings().limits);
  ASSERT_TRUE(p.found);
  EXPECT_EQ(p.check, StateCheck::kPenetration);
  EXPECT_EQ(p.rod, "cable");
  EXPECT_NE(p.detail.find("'block'"), std::string::npos) << p.detail;
  EXPECT_NE(p.detail.find("(limit 0.5 r)"), std::string::npos) << p.detail;  // the documented text
  StateLimits off;
  off.max_penetration = 0.0;
  EXPECT_FALSE(check_state(s.world, off).found);

  Scene m = inside_box(true);
  m.world.step();
  EXPECT_FALSE(check_state(m.world, GuardSettings().limits).found);
  const std::string report = deep_contact_report(m.world, 0.1);
  EXPECT_NE(report.find("'block'"), std::string::npos) << report;
  EXPECT_NE(report.find("cable"), std::string::npos) << report;
}

// A 1 m cable (r = 3 mm) clamped at both ends; two plates 4 cm wide above and below its middle
// close from 2 cm apart to 2 mm apart (less than its 6 mm diameter) between 0.1 s and 0.2 s,
// hold, then the upper one jumps 3 mm further down within 2 ms (1.5 m/s) and slides 3 cm
// sideways over 0.1 s, dragging the pinched cable by friction.
const char* kPinch =
    "gravity: [0, 0, -9.81]\n"
    "duration: 0.45\n"
    "obstacles:\n"
    "  - name: lower\n"
    "    type: box\n"
    "    size: [0.04, 0.2, 0.02]\n"
    "    position: [0.5, 0, -0.02]\n"
    "    interpolation: linear\n"
    "    keyframes: [{time: 0.1, displacement: [0, 0, 0]}, {time: 0.2, displacement: [0, 0, "
    "0.009]}]\n"
    "  - name: upper\n"
    "    type: box\n"
    "    size: [0.04, 0.2, 0.02]\n"
    "    position: [0.5, 0, 0.02]\n"
    "    interpolation: linear\n"
    "    keyframes: [{time: 0.1, displacement: [0, 0, 0]}, {time: 0.2, displacement: [0, 0, "
    "-0.009]}, {time: 0.3, displacement: [0, 0, -0.009]}, {time: 0.302, displacement: [0, 0, "
    "-0.012]}, {time: 0.4, displacement: [0.03, 0, -0.012]}]\n"
    "rods:\n"
    "  - name: cable\n"
    "    elements: 32\n"
    "    radius: 0.003\n"
    "    material: {preset: soft_cable, E_s: 5.0e7, kappa: 60}\n"
    "    shape: {type: straight, start: [0, 0, 0], direction: [1, 0, 0], length: 1.0}\n"
    "    reference_d1: [0, 1, 0]\n"
    "    boundary:\n"
    "      - {clamp: start, kind: ghost}\n"
    "      - {clamp: end, kind: ghost}\n";

struct PinchResult {
  double fastest = 0.0;               // m/s, any node, every step
  double deepest = 0.0;               // m, the contact stage's report
  std::string report;                 // deep_contact_report at the deepest step
  bool upper = false, lower = false;  // some report named that plate
};

PinchResult run_pinch(const std::string& integrator, const std::string& dt) {
  Scene s = parse_scene(kPinch, {"integrator=" + integrator, "time_step=" + dt});
  PinchResult out;
  const int steps = static_cast<int>(s.duration / s.world.time_step + 0.5);
  for (int k = 0; k < steps; ++k) {
    s.world.step();
    for (const Vec3& v : s.world.rods()[0].velocities())
      out.fastest = std::max(out.fastest, v.norm());
    const double d = s.world.contacts()->stats().max_penetration;
    if (d > 0.1 * 0.003) {
      const std::string rep = deep_contact_report(s.world, 0.1);
      out.upper = out.upper || rep.find("'upper'") != std::string::npos;
      out.lower = out.lower || rep.find("'lower'") != std::string::npos;
      if (d > out.deepest) out.report = rep;
    }
    out.deepest = std::max(out.deepest, d);
  }
  return out;
}

class Pinch : public ::testing::TestWithParam<std::pair<const char*, const char*>> {};

// Before the bound the sweeps' impulses grew without bound between the two plates and launched
// the cable (see the commit for the figures).
TEST_P(Pinch, CableIsPushedOutNotLaunchedAndTheContactIsNamed) {
  const PinchResult p = run_pinch(GetParam().first, GetParam().second);
  EXPECT_LT(p.fastest, 3.0);
  EXPECT_GT(p.deepest, 0.1 * 0.003);  // it is pinched: the plates leave 2 mm for 6 mm
  EXPECT_NE(p.report.find("cable"), std::string::npos) << p.report;
  EXPECT_TRUE(p.upper || p.lower) << p.report;
}

INSTANTIATE_TEST_SUITE_P(Methods, Pinch,
                         ::testing::Values(std::make_pair("implicit_euler", "0.001"),
                                           std::make_pair("bdf2", "0.001"),
                                           std::make_pair("split_rotation", "auto")));

// run_scene (corde_run) reports the pinch throttled, once per deep_contact_interval at most, and
// its summary names the deepest contact.
TEST(ContactDeep, RunSceneReportsDeepContactsThrottled) {
  Scene s = parse_scene(kPinch, {"integrator=implicit_euler", "time_step=0.001"});
  RunOptions o;
  std::vector<std::pair<double, std::string>> reports;
  o.on_deep_contact = [&](double t, const std::string& r) { reports.emplace_back(t, r); };
  const RunResult r = run_scene(&s, o);
  EXPECT_TRUE(r.ok) << r.problem;
  ASSERT_FALSE(reports.empty());
  EXPECT_LE(reports.size(), 5u);  // 0.45 s at one per 0.1 s
  for (size_t i = 1; i < reports.size(); ++i)
    EXPECT_GE(reports[i].first - reports[i - 1].first, o.deep_contact_interval - 1e-9);
  EXPECT_NE(reports[0].second.find("rod 'cable' segment"), std::string::npos) << reports[0].second;
  EXPECT_GT(r.deep_contact_steps, 0);
  EXPECT_GT(r.deepest_contact, 0.1);
  const std::string summary = run_summary(s, r);
  EXPECT_NE(summary.find("contacts   deep in"), std::string::npos) << summary;
}

}  // namespace
}  // namespace corde

namespace corde {
namespace {

// The scene key: read, and refused unless positive (naming the key).
TEST(ContactDeep, DeepPenetrationSceneKey) {
  const std::string rods =
      "rods:\n  - {name: r, radius: 0.003, material: soft_cable, shape: {type: straight}}\n";
  EXPECT_DOUBLE_EQ(
      parse_scene("contact: {deep_penetration: 0.25}\n" + rods).world.contact.deep_penetration,
      0.25);
  EXPECT_DOUBLE_EQ(parse_scene(rods).world.contact.deep_penetration, 0.1);
  try {
    parse_scene("contact: {deep_penetration: 0}\n" + rods);
    ADD_FAILURE() << "deep_penetration 0 accepted";
  } catch (const SceneError& e) {
    EXPECT_NE(std::string(e.what()).find("deep_penetration"), std::string::npos) << e.what();
  }
}

// A link (a box moving at 5 m/s) sweeps down through a cable just beside its clamped end segment
// (a gripper's fingers). The hit segment has one held node, so its contact point moves by 1 - s
// of its free node's change: stopping the link's approach there needed about 1 / (1 - s) times
// its speed at that node, and launched the cable (fastest node 9563 m/s before the bound).
TEST(ContactDeep, LinkBesideAHeldSegmentDoesNotLaunchTheCable) {
  const char* scene =
      "gravity: [0, 0, 0]\n"
      "integrator: split_rotation\n"
      "obstacles:\n"
      "  - name: link\n"
      "    type: box\n"
      "    size: [0.04, 0.1, 0.04]\n"
      "    position: [0.987, 0, 0.025]\n"
      "    interpolation: linear\n"
      "    keyframes: [{time: 0.01, displacement: [0, 0, 0]}, {time: 0.03, displacement: [0, 0, "
      "-0.1]}]\n"
      "rods:\n"
      "  - name: cable\n"
      "    elements: 32\n"
      "    radius: 0.003\n"
      "    material: {preset: soft_cable, E_s: 5.0e7, kappa: 60}\n"
      "    shape: {type: straight, start: [0, 0, 0], direction: [1, 0, 0], length: 1.0}\n"
      "    boundary:\n"
      "      - {clamp: start, kind: ghost}\n"
      "      - {clamp: end, kind: natural}\n";
  Scene s = parse_scene(scene);
  double fastest = 0.0;
  const int steps = static_cast<int>(0.05 / s.world.time_step + 0.5);
  for (int k = 0; k < steps; ++k) {
    s.world.step();
    for (const Vec3& v : s.world.rods()[0].velocities()) fastest = std::max(fastest, v.norm());
  }
  std::printf("link beside a held segment: fastest node %.3g m/s\n", fastest);
  // Bounded: 18 m/s (each contact on the segment may give its free node the approach speed plus
  // max_push_speed), against 9563 m/s before.
  EXPECT_GT(fastest, 1.0);   // the link does push the cable
  EXPECT_LT(fastest, 25.0);  // at most five times the link's speed, not launched
}

}  // namespace
}  // namespace corde
