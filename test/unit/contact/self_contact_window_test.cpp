// Self contact near along the rod: the documented neighbour window and folds at single nodes.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "corde_sim/contact/segment_distance.h"
#include "corde_sim/scene/scene.h"
#include "corde_sim/world/world.h"

namespace corde {
namespace {

constexpr double kPi = 3.14159265358979323846;

// The closest two points of segments i and j of a rod's axis may come: a rod of radius r bent
// no tighter than its radius (axis curvature radius r) keeps points at arc distance L at least
// 2 r sin(L / 2r) apart, 2 r once L >= pi r. L: the rest length between the segments' near nodes.
double allowed_distance(const Rod& rod, int i, int j) {
  const double r = rod.section().radius;
  double arc = 0.0;
  for (int k = i + 1; k < j; ++k) arc += rod.rest_lengths()[k];
  return arc >= kPi * r ? 2.0 * r : 2.0 * r * std::sin(arc / (2.0 * r));
}

// The deepest overlap of two non-adjacent segments of the rod beyond what its thickness allows.
double deepest_fold_overlap(const Rod& rod, int* at_i = nullptr, int* at_j = nullptr) {
  const auto& x = rod.positions();
  double worst = -INFINITY;
  for (int i = 0; i < rod.num_segments(); ++i)
    for (int j = i + 2; j < rod.num_segments(); ++j) {
      const SegmentPair p = closest_points(x[i], x[i + 1], x[j], x[j + 1]);
      const double d = (x[i] + p.s * (x[i + 1] - x[i]) - x[j] - p.t * (x[j + 1] - x[j])).norm();
      const double overlap = allowed_distance(rod, i, j) - d;
      if (overlap > worst) {
        worst = overlap;
        if (at_i) *at_i = i;
        if (at_j) *at_j = j;
      }
    }
  return worst;
}

// docs/scene_format.md: segments closer along the rod than 1 + ceil(0.8 pi r / l) are neighbours;
// with r = 5 mm and l = 1 cm that is 3, so segments 3 apart collide. A rod bent into a narrow U
// (legs 0 and 3 parallel, 0.8 r apart) meets itself between its legs.
TEST(SelfContactWindow, SegmentsAtTheDocumentedCountCollide) {
  const double r = 0.005, l = 0.01;
  ASSERT_EQ(1 + static_cast<int>(std::ceil(0.8 * kPi * r / l)), 3);
  const double a = 0.8 * r, b = std::sqrt(l * l - a * a);  // the V between the legs
  char buf[900];
  std::snprintf(buf, sizeof buf,
                "gravity: [0, 0, 0]\ntime_step: 1.0e-5\n"
                "rods:\n  - name: u\n    elements: 4\n    radius: %g\n"
                "    material: {E: 1.0e6, nu: 0.5, rho: 1000}\n"
                "    shape: {type: polyline, points: [[0, %.17g, 0], [0, 0, 0], [%.17g, %.17g, 0], "
                "[%.17g, 0, 0], [%.17g, %.17g, 0]]}\n"
                "    contact: {self: true}\n",
                r, l, a, -b, 2 * a, 2 * a, l);
  Scene s = parse_scene(buf);
  s.world.step();
  ASSERT_NE(s.world.contacts(), nullptr);
  bool legs = false;
  for (const Contact& c : s.world.contacts()->contacts()) {
    EXPECT_NE(std::abs(c.seg_a - c.seg_b), 1) << "adjacent segments share a node";
    if (c.rod_b == 0 && std::abs(c.seg_a - c.seg_b) == 3) {
      legs = true;
      EXPECT_NEAR(c.gap, 2 * a - 2 * r, 1e-3 * r);
    }
  }
  EXPECT_TRUE(legs) << "segments 0 and 3 (3 apart) were not tested";
}

// A straight finely divided rod (l = r / 2: eleven segments within pi r) at rest with self contact
// stays exactly at rest: the near segments are not pushed apart.
TEST(SelfContactWindow, StraightRodIsNotPushedApart) {
  Scene s = parse_scene(
      "gravity: [0, 0, 0]\ntime_step: 1.0e-5\n"
      "rods:\n  - name: r\n    elements: 40\n    radius: 0.005\n"
      "    material: {E: 1.0e6, nu: 0.5, rho: 1000}\n"
      "    shape: {type: straight, start: [0, 0, 0], direction: [1, 0, 0], length: 0.1}\n"
      "    contact: {self: true}\n");
  const auto x0 = s.world.rods()[0].positions();
  s.world.step(200);
  const auto& x = s.world.rods()[0].positions();
  for (size_t k = 0; k < x.size(); ++k) EXPECT_LT((x[k] - x0[k]).norm(), 1e-12) << k;
  for (const Contact& c : s.world.contacts()->contacts()) EXPECT_GT(c.gap, 0.0);
}

// A limp rope (30 elements of 2 r) dropped end first onto a floor buckles and folds; it must not
// fold through itself at a node: no two non-adjacent segments come closer than a rod bent to its
// own radius allows, less 3 % of r (checked every millisecond).
TEST(SelfContactWindow, LimpRopeDroppedOnFloorDoesNotFoldThroughItself) {
  Scene s = parse_scene(
      "gravity: [0, 0, -9.81]\ntime_step: auto\n"
      "contact: {friction: 0.4}\n"
      "obstacles:\n  - {name: floor, type: plane, normal: [0, 0, 1], friction: 0.5}\n"
      "rods:\n  - name: rope\n    elements: 30\n    radius: 0.005\n"
      "    material: {preset: paper_rope, E: 5.0e4, G: 5.0e4}\n"
      "    shape: {type: straight, start: [0, 0, 0.01], direction: [0, 0, 1], length: 0.3}\n"
      "    initial:\n      perturbation: {position: 1.0e-4, seed: 1}\n"
      "    contact: {self: true}\n");
  const Rod& rod = s.world.rods()[0];
  const double r = rod.section().radius;
  const int per = std::max(1, static_cast<int>(std::lround(1e-3 / s.world.time_step)));
  double worst = -INFINITY, when = 0.0;
  int wi = -1, wj = -1;
  for (int k = 1; k <= 600; ++k) {
    s.world.step(per);
    ASSERT_TRUE(s.world.finite());
    int i = -1, j = -1;
    const double o = deepest_fold_overlap(rod, &i, &j);
    if (o > worst) {
      worst = o;
      when = s.world.time();
      wi = i;
      wj = j;
    }
  }
  // It did fold: the rope lies on the floor, much lower than it stood.
  EXPECT_LT(rod.center_of_mass().z(), 0.05);
  EXPECT_LT(worst, 0.03 * r) << "segments " << wi << " and " << wj << " at t = " << when << " s";
}

}  // namespace
}  // namespace corde
