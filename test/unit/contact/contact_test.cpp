// Contacts: closest points of segments, rods resting and sliding on obstacles with Coulomb
// friction, nothing tunnelling, rods on rods and a twisted rod on itself.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "corde_sim/contact/segment_distance.h"
#include "corde_sim/rod/rod_shape.h"
#include "corde_sim/scene/scene.h"
#include "corde_sim/world/world.h"
#include "dynamics_util.h"

namespace corde {
namespace {

using dyn::mean_velocity;

constexpr double kPi = 3.14159265358979323846;

TEST(SegmentDistance, MatchesBruteForce) {
  std::mt19937 gen(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  auto rnd = [&] { return Vec3(u(gen), u(gen), u(gen)); };
  for (int trial = 0; trial < 2000; ++trial) {
    const Vec3 p0 = rnd(), q0 = rnd();
    Vec3 p1 = rnd(), q1 = rnd();
    if (trial % 7 == 0) q1 = q0 + 0.7 * (p1 - p0);  // parallel
    if (trial % 11 == 0) p1 = p0;                   // a point
    const SegmentPair sp = closest_points(p0, p1, q0, q1);
    const double d = (p0 + sp.s * (p1 - p0) - q0 - sp.t * (q1 - q0)).norm();
    double best = INFINITY;
    const int k = 200;
    for (int i = 0; i <= k; ++i) {
      // For each s the best t is a clamped projection: exact in t, sampled in s.
      const Vec3 p = p0 + (double(i) / k) * (p1 - p0);
      const Vec3 e = q1 - q0;
      const double t =
          e.squaredNorm() > 0 ? std::clamp((p - q0).dot(e) / e.squaredNorm(), 0.0, 1.0) : 0.0;
      best = std::min(best, (p - q0 - t * e).norm());
    }
    EXPECT_LE(d, best + 1e-12) << trial;
    EXPECT_GE(d, best - 2.0 / k) << trial;  // the sampling's resolution
    EXPECT_GE(sp.s, 0.0);
    EXPECT_LE(sp.s, 1.0);
    EXPECT_GE(sp.t, 0.0);
    EXPECT_LE(sp.t, 1.0);
  }
}

// A world with no obstacles and no rod asking for rod or self contact does no contact work.
TEST(Contacts, NoneWithoutObstaclesOrRequests) {
  Scene s =
      parse_scene("rods:\n  - {material: soft_cable, elements: 10, shape: {type: straight}}\n");
  EXPECT_FALSE(ContactSystem::needed(s.world));
  s.world.step(10);
  EXPECT_EQ(s.world.contacts(), nullptr);
  s.world.rods()[0].contact_options().self = true;
  EXPECT_TRUE(ContactSystem::needed(s.world));
}

std::string rope_on_plane(double tilt_deg, double mu, double elements = 20) {
  const double a = tilt_deg * kPi / 180.0;
  char buf[1200];
  // A 0.5 m rope lying down the slope of a plane tilted about y, released at rest just above it.
  const double r = 0.005, l = 0.5;
  const Vec3 down(std::cos(a), 0.0, -std::sin(a)), up_normal(std::sin(a), 0.0, std::cos(a));
  const Vec3 start = (r * 1.0) * up_normal;
  std::snprintf(buf, sizeof buf,
                "gravity: [0, 0, -9.81]\ntime_step: auto\nduration: 1.0\n"
                "obstacles:\n  - {name: slope, type: plane, normal: [%.17g, 0, %.17g], friction: "
                "%.17g}\n"
                "rods:\n  - name: rope\n    elements: %d\n    radius: %g\n"
                "    material: {E: 1.0e6, nu: 0.5, rho: 1000, damping_time: 1.0e-3}\n"
                "    shape: {type: straight, start: [%.17g, 0, %.17g], direction: [%.17g, 0, "
                "%.17g], length: %g}\n",
                up_normal.x(), up_normal.z(), mu, static_cast<int>(elements), r, start.x(),
                start.z(), down.x(), down.z(), l);
  return buf;
}

// Static friction holds a rope on a slope with tan(theta) < mu; with tan(theta) > mu it slides
// with a = g (sin theta - mu cos theta), within 2%.
TEST(Contacts, RopeOnTiltedPlaneSticksOrSlides) {
  const double g = 9.81;
  {
    Scene s = parse_scene(rope_on_plane(20.0, 0.5));  // tan 20 deg = 0.36 < 0.5
    s.world.step(static_cast<int>(0.5 / s.world.time_step));
    const Vec3 x0 = s.world.rods()[0].center_of_mass();
    s.world.step(static_cast<int>(0.5 / s.world.time_step));
    const double a = 20.0 * kPi / 180.0;
    const Vec3 down(std::cos(a), 0.0, -std::sin(a));
    // It stays put (no creep along the slope), to the rope's own settling.
    EXPECT_LT(std::abs((s.world.rods()[0].center_of_mass() - x0).dot(down)), 1e-6);
    EXPECT_LT(mean_velocity(s.world.rods()[0]).norm(), 1e-4);
  }
  for (double tilt : {30.0, 45.0}) {
    const double mu = 0.3, a = tilt * kPi / 180.0;
    Scene s = parse_scene(rope_on_plane(tilt, mu));
    const int half = static_cast<int>(0.25 / s.world.time_step);
    s.world.step(half);
    const Vec3 v0 = mean_velocity(s.world.rods()[0]);
    s.world.step(2 * half);
    const Vec3 v1 = mean_velocity(s.world.rods()[0]);
    const double accel = (v1 - v0).norm() / (2 * half * s.world.time_step);
    const double want = g * (std::sin(a) - mu * std::cos(a));
    EXPECT_NEAR(accel, want, 0.02 * want) << tilt;
    EXPECT_LT(s.world.contacts()->stats().max_penetration, 0.01 * 0.005) << tilt;
  }
}

// Smallest distance between the axes of two segments of the same rod more than `skip` apart, or
// of two rods.
double min_axis_distance(const Rod& a, const Rod* b, int skip) {
  double best = INFINITY;
  const auto& xa = a.positions();
  const Rod& other = b ? *b : a;
  const auto& xb = other.positions();
  for (int i = 0; i < a.num_segments(); ++i)
    for (int j = b ? 0 : i + skip + 1; j < other.num_segments(); ++j) {
      const SegmentPair p = closest_points(xa[i], xa[i + 1], xb[j], xb[j + 1]);
      best = std::min(
          best, (xa[i] + p.s * (xa[i + 1] - xa[i]) - xb[j] - p.t * (xb[j + 1] - xb[j])).norm());
    }
  return best;
}

// The paper's Fig. 1 with self-contact: a rope clamped at both ends, one end turning, coils until
// its loop lands on itself; no two non-neighbouring segments come closer than the diameter (less
// 1% of the radius), checked every 10 ms.
TEST(Contacts, TwistedRodNeverPassesThroughItself) {
  // The end turns at 2 rev/s (the scene's 0.5 rev/s takes 17 s to bring the loop onto itself).
  Scene s = load_scene(std::string(CORDE_SIM_SOURCE_DIR) + "/config/scenes/coiling_50.yaml",
                       {"rods.0.contact={self: true}", "rods.0.boundary.1.spin_rate=12.566"});
  Rod& rod = s.world.rods()[0];
  const double r = rod.section().radius;
  const int skip = 1 + static_cast<int>(std::ceil(0.8 * kPi * r / rod.rest_lengths()[0]));
  double closest = INFINITY;
  int most = 0;
  const int per = static_cast<int>(std::lround(0.01 / s.world.time_step));
  for (int k = 1; k <= 850; ++k) {  // 8.5 s: 17 turns of the end; the loop lands at about 8 s
    for (int i = 0; i < per; ++i) {
      s.world.step();
      most = std::max(most, s.world.contacts()->stats().active);
    }
    ASSERT_TRUE(s.world.finite());
    closest = std::min(closest, min_axis_distance(rod, nullptr, skip));
  }
  EXPECT_GT(closest, 2.0 * r - 0.01 * r);
  EXPECT_LT(closest, 2.0 * r * 1.05);  // it did rest on itself
  EXPECT_GT(most, 0);
}

// A rope dropped across a clamped rope drapes over it and stays on top: the axes never come
// closer than the sum of the radii (less 1% of a radius).
TEST(Contacts, RopeDropsOntoRopeAndStaysOnTop) {
  Scene s = parse_scene(
      "gravity: [0, 0, -9.81]\ntime_step: 2.0e-5\n"
      "rods:\n"
      "  - {name: lower, elements: 30, radius: 0.005, material: {E: 1.0e6, nu: 0.5, rho: 1000, "
      "damping_time: 1.0e-3}, shape: {type: straight, start: [-0.3, 0, 0], direction: [1, 0, 0], "
      "length: 0.6}, boundary: [{clamp: start}, {clamp: end}], contact: {rods: true}}\n"
      "  - {name: upper, elements: 30, radius: 0.005, material: {E: 1.0e6, nu: 0.5, rho: 1000, "
      "damping_time: 1.0e-3}, shape: {type: straight, start: [0.02, -0.3, 0.05], direction: [0, 1, "
      "0], length: 0.6}, contact: {rods: true}}\n");
  const Rod &lower = s.world.rods()[0], &upper = s.world.rods()[1];
  double closest = INFINITY;
  for (int k = 0; k < 40; ++k) {
    s.world.step(1000);  // 0.8 s in all: falls 5 cm (0.1 s), lands, drapes
    closest = std::min(closest, min_axis_distance(upper, &lower, 0));
  }
  EXPECT_GT(closest, 0.01 - 0.01 * 0.005);
  // Draped over it: the upper rope's middle rests on the lower rope's middle, its ends hang.
  EXPECT_GT(upper.positions()[15].z(), lower.positions()[15].z());
  EXPECT_LT(upper.positions()[0].z(), upper.positions()[15].z() - 0.1);
  EXPECT_LT(closest, 0.0102);  // resting on it
}

// A rod falling 2 m onto a 1 cm plate lands on it (6.3 m/s at impact, 0.63 mm a step).
TEST(Contacts, FallingRodDoesNotTunnelThroughAThinPlate) {
  Scene s = parse_scene(
      "gravity: [0, 0, -9.81]\ntime_step: 1.0e-4\n"
      "obstacles:\n  - {name: plate, type: box, size: [1, 1, 0.01], position: [0, 0, -0.005]}\n"
      "rods:\n  - {name: rod, elements: 20, radius: 0.004, material: {E: 1.0e7, nu: 0.5, rho: "
      "1000, damping_time: 1.0e-4}, shape: {type: straight, start: [-0.2, 0, 2.0], direction: [1, "
      "0, 0.2], length: 0.4}}\n");
  const Rod& rod = s.world.rods()[0];
  double lowest = INFINITY;
  for (int k = 0; k < 10000; ++k) {  // 1 s
    s.world.step();
    for (const Vec3& x : rod.positions()) lowest = std::min(lowest, x.z());
  }
  EXPECT_GT(lowest, 0.004 - 0.01 * 0.004);
  EXPECT_LT(rod.center_of_mass().z(), 0.05);  // it did land
}

}  // namespace
}  // namespace corde
