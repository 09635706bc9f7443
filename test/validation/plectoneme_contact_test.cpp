// The CoRdE paper's Fig. 1 with self contact (config/scenes/plectoneme_contact.yaml, run as
// shipped): a filament clamped at both ends, one clamp turned by 8 turns, winds into loops and a
// plectoneme that rests on itself. Checks that it never passes through itself, that the turns go
// into writhe with the link Tw + Wr following the clamp, and that the plectoneme ends at rest on
// its own contacts. The same run without self contact is the control: every check fails there.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "corde_sim/contact/segment_distance.h"
#include "corde_sim/scene/scene.h"
#include "corde_sim/world/world.h"
#include "writhe.h"

namespace corde {
namespace {

constexpr double kPi = 3.14159265358979323846;

double axis_distance(const std::vector<Vec3>& x, int i, int j) {
  const SegmentPair p = closest_points(x[i], x[i + 1], x[j], x[j + 1]);
  return (x[i] + p.s * (x[i + 1] - x[i]) - x[j] - p.t * (x[j + 1] - x[j])).norm();
}

// The smallest distance between the axes of segments more than `skip` apart along the rod, after
// every step, exact below `watch` at a fraction of the cost of all pairs: a Verlet list. A full
// pass keeps the pairs closer than watch + margin; a segment's points move by at most h v_max in
// a step (node speeds, the step's new velocities), so a pair's distance changes by at most
// 2 h v_max, and until those changes add up to the margin no pair outside the list gets below
// watch.
class ClosestApproach {
 public:
  ClosestApproach(int skip, double watch, double margin)
      : skip_(skip), watch_(watch), margin_(margin) {}
  void update(const Rod& rod, double h) {
    double v_max = 0.0;
    for (const Vec3& v : rod.velocities()) v_max = std::max(v_max, v.norm());
    budget_ -= 2.0 * h * v_max;
    const auto& x = rod.positions();
    if (budget_ < 0.0) {
      near_.clear();
      for (int i = 0; i < rod.num_segments(); ++i)
        for (int j = i + skip_ + 1; j < rod.num_segments(); ++j) {
          const double d = axis_distance(x, i, j);
          closest = std::min(closest, d);
          if (d < watch_ + margin_) near_.push_back({i, j});
        }
      budget_ = margin_;
      return;
    }
    for (const auto& [i, j] : near_) closest = std::min(closest, axis_distance(x, i, j));
  }
  double closest = INFINITY;

 private:
  int skip_;
  double watch_, margin_, budget_ = -1.0;
  std::vector<std::pair<int, int>> near_;
};

struct Sample {
  double turns, tw, wr;  // the end clamp's turns, the rod's twist and writhe
};

struct Result {
  double radius = 0.0;
  double closest = INFINITY;        // over samples every 10 ms
  double max_penetration = 0.0;     // the contact stage's report, every step
  std::vector<Sample> samples;      // when the clamp first reaches 2, 4, 6 turns, and at the end
  int active = 0, self_active = 0;  // contacts carrying force at the end (self: both on the rod)
  double normal_force = 0.0;        // N, their sum at the end
  double kinetic = 0.0, elastic = 0.0;
};

Result run(bool self_contact) {
  Scene s =
      load_scene(std::string(CORDE_SIM_SOURCE_DIR) + "/config/scenes/plectoneme_contact.yaml",
                 {self_contact ? "rods.0.contact={self: true}" : "rods.0.contact={self: false}"});
  World& w = s.world;
  const Rod& rod = w.rods()[0];
  Result r;
  r.radius = rod.section().radius;
  const int skip = 1 + static_cast<int>(std::ceil(0.8 * kPi * r.radius / rod.rest_lengths()[0]));
  // The clamp's turns: its ghost frame's rotation about the axis, unwrapped sample by sample.
  const Quat q0 = rod.ghost_end().frame;
  double turned = 0.0, last = 0.0;
  double next_mark = 2.0;
  const int per = static_cast<int>(std::lround(0.01 / w.time_step));
  ClosestApproach approach(skip, 2.0 * r.radius, 0.5 * r.radius);
  while (w.time() < s.duration - 0.5 * w.time_step) {
    for (int i = 0; i < per; ++i) {
      w.step();
      if (w.contacts())
        r.max_penetration = std::max(r.max_penetration, w.contacts()->stats().max_penetration);
      approach.update(rod, w.time_step);
    }
    if (!w.finite()) {
      ADD_FAILURE() << "blew up at t = " << w.time();
      return r;
    }
    const Quat q = rod.ghost_end().frame * q0.conjugate();
    const double angle = 2.0 * std::atan2(q.vec().dot(Vec3::UnitX()), q.w());
    turned += std::remainder(angle - last, 2.0 * kPi);
    last = angle;
    if (turned / (2.0 * kPi) >= next_mark && next_mark < 8.0) {
      r.samples.push_back({turned / (2.0 * kPi), twist_turns(rod), writhe(rod)});
      next_mark += 2.0;
    }
  }
  r.samples.push_back({turned / (2.0 * kPi), twist_turns(rod), writhe(rod)});
  r.closest = approach.closest;
  if (w.contacts()) {
    for (const Contact& c : w.contacts()->contacts()) {
      if (c.pn <= 0.0) continue;
      ++r.active;
      if (c.rod_b == c.rod_a) ++r.self_active;
      r.normal_force += c.pn / w.time_step;
    }
  }
  const WorldEnergies e = w.energies();
  r.kinetic = e.kinetic();
  r.elastic = e.elastic();
  return r;
}

void print(const char* what, const Result& r) {
  std::printf("%s: closest %.6f (2r), max penetration %.2e r\n", what, r.closest / (2.0 * r.radius),
              r.max_penetration / r.radius);
  for (const Sample& s : r.samples)
    std::printf("  %.4f turns: Tw %.4f, Wr %.4f, Tw + Wr %.4f\n", s.turns, s.tw, s.wr, s.tw + s.wr);
  std::printf(
      "  at the end: %d contacts carrying force (%d self), %.3e N in all, kinetic %.2e J, "
      "elastic %.4e J\n",
      r.active, r.self_active, r.normal_force, r.kinetic, r.elastic);
}

// The shipped scene with self contact, run once for the three tests (about 3 s of CPU).
const Result& with_contact() {
  static const Result r = [] {
    Result x = run(true);
    print("plectoneme_contact", x);
    return x;
  }();
  return r;
}

TEST(PlectonemeContact, NeverPassesThroughItself) {
  const Result& r = with_contact();
  EXPECT_GT(r.closest, 2.0 * r.radius - 0.01 * r.radius);  // measured 2r - 0.0001 r
  EXPECT_LT(r.closest, 2.0 * r.radius * 1.01);             // and it did touch itself
  EXPECT_LT(r.max_penetration, 0.01 * r.radius);           // measured 1e-4 r
}

TEST(PlectonemeContact, WritheGrowsAndLinkFollowsTheTurns) {
  const Result& r = with_contact();
  ASSERT_EQ(r.samples.size(), 4u);  // 2, 4, 6 and 8 turns
  for (size_t k = 0; k < r.samples.size(); ++k) {
    const Sample& s = r.samples[k];
    SCOPED_TRACE(s.turns);
    // Calugareanu-White: the link Tw + Wr is the clamp's turns (measured within 0.016).
    EXPECT_NEAR(s.tw + s.wr, s.turns, 0.03);
    if (k > 0) {
      EXPECT_GT(s.wr, r.samples[k - 1].wr + 0.05);  // writhe grows with the turns
    }
  }
  EXPECT_NEAR(r.samples.back().turns, 8.0, 1e-6);
  EXPECT_GT(r.samples.back().wr, 2.0);  // the plectoneme: measured Wr 2.54, Tw 5.44
}

TEST(PlectonemeContact, RestsOnItselfAtTheEnd) {
  const Result& r = with_contact();
  EXPECT_GE(r.self_active, 3);  // the strands touch in several places (measured 6)
  EXPECT_EQ(r.self_active, r.active);
  EXPECT_GT(r.normal_force, 1e-4);         // N (measured 1.08)
  EXPECT_LT(r.kinetic, 1e-9 * r.elastic);  // at rest (measured 2e-14 of the elastic energy)
}

// The control: without self contact the loop passes through itself (the link drops by 2 turns
// each time), the axes come closer than a diameter and nothing rests on anything.
TEST(PlectonemeContact, WithoutSelfContactEveryCheckFails) {
  const Result r = run(false);
  print("without self contact", r);
  EXPECT_LT(r.closest, 2.0 * r.radius - 0.01 * r.radius);
  const Sample& end = r.samples.back();
  EXPECT_GT(std::abs(end.tw + end.wr - end.turns), 1.0);
  EXPECT_LT(end.wr, 2.0);
  EXPECT_EQ(r.active, 0);
}

}  // namespace
}  // namespace corde
