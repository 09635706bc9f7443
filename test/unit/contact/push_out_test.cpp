// Push-out of a penetration: a rope that starts slightly inside an obstacle is moved out of it
// without being thrown off (the push-out is a correction of positions, not momentum).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "corde_sim/scene/scene.h"
#include "corde_sim/world/world.h"

namespace corde {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDrum = 0.05, kR = 0.005;

// A rope (r = 5 mm, 10 elements) laid over the top of a drum (radius 50 mm, axis along y) as a
// polyline inscribed in the circle of radius R + r: its nodes touch the drum and its segments'
// middles are 4.6 % of r inside. Its rest shape is the one created, so only gravity and the
// contacts act on it. A start this deep is refused at load (a scene's rope must start clear), so
// the scene is loaded with a thinner drum, which is then given its radius: the state a rope
// pushed slightly into an obstacle (by a grasp or a link) is in.
Scene inscribed_rope(const char* integrator, const char* step) {
  const double rc = kDrum + kR, dtheta = 2.0 * std::acos(1.0 - 0.046 * kR / rc);
  std::string points;
  for (int k = 0; k <= 10; ++k) {
    const double a = (k - 5) * dtheta;
    char p[96];
    std::snprintf(p, sizeof p, "%s[%.17g, 0, %.17g]", k ? ", " : "", rc * std::sin(a),
                  rc * std::cos(a));
    points += p;
  }
  char buf[2000];
  std::snprintf(buf, sizeof buf,
                "gravity: [0, 0, -9.81]\ntime_step: %s\nintegrator: %s\n"
                "obstacles:\n  - {name: drum, type: cylinder, radius: %.17g, length: 0.1, "
                "rpy: [1.5707963267948966, 0, 0], friction: 0.5}\n"
                "rods:\n  - name: rope\n    elements: 10\n    radius: %.17g\n"
                "    material: nylon_rope\n    rest_shape: created\n"
                "    shape: {type: polyline, points: [%s]}\n",
                step, integrator, kDrum - 0.1 * kR, kR, points.c_str());
  Scene s = parse_scene(buf);
  Obstacle drum = s.world.obstacles->obstacle(0);
  drum.shape.size.x() = kDrum;
  s.world.obstacles->replace(0, drum);
  return s;
}

// The drum's axis is the world y axis: a point's distance from it, and its angle about it.
double axis_distance(const Vec3& p) { return std::hypot(p.x(), p.z()); }
double angle(const Vec3& p) { return std::atan2(p.x(), p.z()); }

// The inscribed rope is pushed out until its segments' middles touch the drum (its nodes then
// 4.6 % of r clear), and no further: it never lifts off by more than 5 % of r beyond that, it
// keeps no speed from the push-out and it does not slide round the drum.
TEST(PushOut, InscribedRopeIsMovedOutWithoutBeingThrownOff) {
  struct Case {
    const char* integrator;
    const char* step;
  };
  for (const Case& c : {Case{"semi_implicit_euler", "auto"}, Case{"implicit_euler", "1.0e-3"}}) {
    Scene s = inscribed_rope(c.integrator, c.step);
    World& world = s.world;
    const Rod& rod = world.rods()[0];
    const double angle0 = angle(rod.positions()[5]);
    double lift = 0.0, fastest = 0.0;  // the largest clearance of a segment's middle, node speed
    while (world.time() < 0.3) {
      world.step();
      for (int k = 0; k < rod.num_segments(); ++k) {
        const Vec3 mid = 0.5 * (rod.positions()[k] + rod.positions()[k + 1]);
        lift = std::max(lift, axis_distance(mid) - kDrum - kR);
      }
      for (const Vec3& v : rod.velocities()) fastest = std::max(fastest, v.norm());
    }
    double deepest = 0.0, speed = 0.0;
    for (int k = 0; k < rod.num_segments(); ++k) {
      const Vec3 mid = 0.5 * (rod.positions()[k] + rod.positions()[k + 1]);
      deepest = std::max(deepest, kDrum + kR - axis_distance(mid));
    }
    for (const Vec3& v : rod.velocities()) speed = std::max(speed, v.norm());
    const double slide = (angle(rod.positions()[5]) - angle0) * (kDrum + kR);
    std::printf(
        "%s h %s: lifted %.3g r at most, %.3g r deep at 0.3 s, fastest node %.3g m/s, "
        "%.3g m/s at 0.3 s, slid %.3g mm\n",
        c.integrator, c.step, lift / kR, deepest / kR, fastest, speed, 1e3 * slide);
    EXPECT_LT(lift, 0.05 * kR) << c.integrator;
    EXPECT_LT(deepest, 0.01 * kR) << c.integrator;
    EXPECT_LT(fastest, 0.05) << c.integrator;
    EXPECT_LT(speed, 1e-3) << c.integrator;
    EXPECT_LT(std::abs(slide), 1e-3) << c.integrator;
  }
}

TEST(PushOut, TimeKeyIsReadAndCheckedWithItsPath) {
  const std::string rod =
      "rods:\n  - {name: r, material: {preset: nylon_rope}, shape: {type: straight}}\n";
  EXPECT_EQ(parse_scene(rod + "contact: {push_out_time: 0.002}\n").world.contact.push_out_time,
            0.002);
  EXPECT_EQ(parse_scene(rod).world.contact.push_out_time, ContactSettings().push_out_time);
  for (const char* bad : {"-0.1", "1e10", ".nan", "soon"}) {
    try {
      parse_scene(rod + "contact: {push_out_time: " + bad + "}\n");
      ADD_FAILURE() << "push_out_time: " << bad << " accepted";
    } catch (const std::exception& e) {
      EXPECT_NE(std::string(e.what()).find("contact.push_out_time"), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace corde
