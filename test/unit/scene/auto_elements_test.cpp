// elements: auto: the chosen count meets the shape tolerance against a converged reference, and
// half of it does not; bad tolerances and numeric indices on auto rods are refused.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <string>
#include <vector>

#include "corde_sim/scene/scene.h"

namespace corde {
namespace {

// A damped soft cantilever sagging under gravity (L = 0.5 m): second order (ghost clamp).
std::string cantilever(const std::string& elements, const std::string& tolerance,
                       const std::string& clamp = "ghost") {
  return "duration: 0.3\n" + (tolerance.empty() ? "" : "shape_tolerance: " + tolerance + "\n") +
         "rods:\n"
         "  - name: beam\n"
         "    elements: " +
         elements +
         "\n"
         "    radius: 0.01\n"
         "    material: {E: 1.0e6, nu: 0.5, rho: 1000, damping_time: 0.001}\n"
         "    shape: {type: straight, direction: [1, 0, 0], length: 0.5}\n"
         "    boundary: [{clamp: start, kind: " +
         clamp + "}]\n";
}

// Node positions every 0.03 s over the run (the world stepped directly: no grasps).
std::vector<std::vector<Vec3>> trajectory(const std::string& text, double h) {
  char step[40];
  std::snprintf(step, sizeof step, "time_step=%.17g", h);
  Scene s = parse_scene(text, {step});
  std::vector<std::vector<Vec3>> out{s.world.rods()[0].positions()};
  const int per = static_cast<int>(std::lround(0.03 / h));
  for (int k = 0; k < 10; ++k) {
    s.world.step(per);
    out.push_back(s.world.rods()[0].positions());
  }
  return out;
}

// Largest distance of a trajectory's nodes from the reference at the same rest fraction (equal
// elements: a node i of N sits at i / N of the length).
double max_difference(const std::vector<std::vector<Vec3>>& a,
                      const std::vector<std::vector<Vec3>>& ref) {
  double d = 0.0;
  for (size_t f = 0; f < a.size(); ++f) {
    const int n = static_cast<int>(a[f].size()) - 1, m = static_cast<int>(ref[f].size()) - 1;
    for (int i = 0; i <= n; ++i) {
      const double s = static_cast<double>(i) / n * m;
      const int j = std::min(static_cast<int>(s), m - 1);
      const Vec3 x = ref[f][j] + (s - j) * (ref[f][j + 1] - ref[f][j]);
      d = std::max(d, (a[f][i] - x).norm());
    }
  }
  return d;
}

TEST(AutoElements, ChosenCountMeetsTheToleranceAndHalfOfItDoesNot) {
  const double tol = 2e-3, length = 0.5;
  const Scene s = parse_scene(cantilever("auto", "0.002"));
  const int n = s.world.rods()[0].num_segments();
  ASSERT_EQ(s.notes.size(), 1u);
  EXPECT_NE(s.notes[0].find("elements: auto chose " + std::to_string(n)), std::string::npos)
      << s.notes[0];
  EXPECT_NE(s.notes[0].find("validation suite: 2"), std::string::npos) << s.notes[0];
  // Probed at 8/16, 16/32 and 32/64: the scene's own order (1.85) is reported and, being lower
  // than the suite's, used.
  EXPECT_NE(s.notes[0].find("observed on the scene"), std::string::npos) << s.notes[0];
  EXPECT_GE(n, 8);
  EXPECT_LE(n, 200);
  // The reference at 4N (its error 1/16 of N's); one step for all runs (the finest one's stable
  // step), so that only N differs.
  const std::string fine = cantilever(std::to_string(4 * n), "");
  const double h = parse_scene(fine).world.time_step;
  const auto ref = trajectory(fine, h);
  const double at_n = max_difference(trajectory(cantilever(std::to_string(n), ""), h), ref);
  const double at_half = max_difference(trajectory(cantilever(std::to_string(n / 2), ""), h), ref);
  // The estimate may err by its own O(N^-2) share: within 1.5x of the tolerance at N, and half of
  // N must miss it (else N was not the fewest to a factor 2).
  std::printf("N = %d: %.3g mm, N/2: %.3g mm, tolerance %.3g mm\n", n, at_n * 1e3, at_half * 1e3,
              tol * length * 1e3);
  EXPECT_LE(at_n, 1.5 * tol * length) << "N = " << n;
  EXPECT_GT(at_half, tol * length) << "N = " << n;
}

TEST(AutoElements, TighterToleranceNeedsMoreElementsByTheOrder) {
  const int coarse = parse_scene(cantilever("auto", "0.004")).world.rods()[0].num_segments();
  const int fine = parse_scene(cantilever("auto", "0.001")).world.rods()[0].num_segments();
  // Second order: a 4x tighter tolerance needs about 2x the elements.
  EXPECT_NEAR(static_cast<double>(fine) / coarse, 2.0, 0.5) << coarse << " " << fine;
}

TEST(AutoElements, NaturalClampIsFirstOrder) {
  const Scene s = parse_scene(cantilever("auto", "0.01", "natural"));
  ASSERT_EQ(s.notes.size(), 1u);
  EXPECT_NE(s.notes[0].find("validation suite: 1"), std::string::npos) << s.notes[0];
}

TEST(AutoElements, RodsWithAFixedCountAreLeftAlone) {
  const Scene s = parse_scene(
      "duration: 0.1\nrods:\n"
      "  - {name: a, elements: 7, material: soft_cable, shape: {type: straight}}\n"
      "  - {name: b, elements: auto, material: soft_cable, boundary: [{clamp: start}],\n"
      "     shape: {type: straight, start: [0, 1, 0]}}\n");
  EXPECT_EQ(s.world.rods()[0].num_segments(), 7);
  ASSERT_EQ(s.notes.size(), 1u);
  EXPECT_NE(s.notes[0].find("rods[1] 'b'"), std::string::npos) << s.notes[0];
}

void expect_error(const std::string& text, const std::string& needle) {
  try {
    parse_scene(text);
    ADD_FAILURE() << "no error, expected one containing " << needle;
  } catch (const SceneError& e) {
    EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
  }
}

TEST(AutoElements, BadToleranceIsRefusedNamingTheKey) {
  expect_error(cantilever("auto", "0"), "shape_tolerance: must be in [1e-05, 0.1]");
  expect_error(cantilever("auto", "0.5"), "shape_tolerance: must be in [1e-05, 0.1]");
  expect_error(cantilever("auto", "-1e-3"), "shape_tolerance: must be in");
  expect_error(cantilever("auto", ".nan"), "shape_tolerance");
  expect_error(cantilever("auto", "fine"), "shape_tolerance");
  expect_error(cantilever("many", ""), "rods[0].elements");
}

TEST(AutoElements, NumericIndexOnAnAutoRodIsRefused) {
  expect_error(cantilever("auto", "") + "    loads: [{node: 5, force: [0, 0, -1]}]\n",
               "rods[0].loads[0].node: a node index needs a fixed element count");
  expect_error(
      "rods:\n  - {elements: auto, material: soft_cable, shape: {type: straight},\n"
      "     boundary: [{segment: 3, fix: true}]}\n",
      "rods[0].boundary[0].segment: a segment index needs a fixed element count");
  expect_error(
      "rods:\n  - {elements: auto, material: soft_cable, shape: {type: straight}}\n"
      "grasps: [{name: g, place: node, value: 4}]\n",
      "grasps[0].value: a node index needs a fixed element count");
}

TEST(AutoElements, ToleranceWithoutAutoIsAWarning) {
  const Scene s = parse_scene(cantilever("10", "0.001"));
  ASSERT_EQ(s.warnings.size(), 1u);
  EXPECT_NE(s.warnings[0].find("shape_tolerance"), std::string::npos);
  EXPECT_TRUE(s.notes.empty());
}

}  // namespace
}  // namespace corde
