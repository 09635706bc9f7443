// Rolling resistance (ContactSettings::rolling_friction): a rope spinning about its own axis on a
// floor is braked at the rate a torque of mu_r r N gives, a rope rolling on it decelerates as a
// cylinder under rolling resistance does, a rod-rod contact's couple keeps the angular momentum,
// and bad values are refused with the key's path.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "corde_sim/scene/scene.h"
#include "corde_sim/world/world.h"
#include "friction_util.h"

namespace corde {
namespace {

using friction::rope_motion;

// The lying rope of friction_util.h on a floor with friction 0.5, rolling resistance `rolling`,
// friction at the surfaces or at the axes.
Scene rope_on_floor(double r, double rolling, bool surface, const char* integrator,
                    const char* step, double w0, double vy) {
  char contact[96];
  std::snprintf(contact, sizeof contact, "{surface_friction: %s, rolling_friction: %.17g}",
                surface ? "true" : "false", rolling);
  return friction::lying_rope(r, 0.5, contact, integrator, step, w0, vy);
}

// Runs until `until` s; returns the time (interpolated between steps) at which f() first falls
// to `level`, or -1.
template <class F>
double time_to_fall(World& world, double until, double level, F f) {
  double t_prev = world.time(), f_prev = f(), crossed = -1.0;
  while (world.time() < until) {
    world.step();
    const double now = f();
    if (crossed < 0.0 && now <= level)
      crossed = t_prev + (world.time() - t_prev) * (f_prev - level) / (f_prev - now);
    t_prev = world.time();
    f_prev = now;
  }
  return crossed;
}

// Friction at the axes: the floor cannot brake the spin, rolling resistance can. A torque of
// mu_r r m g on a cylinder spinning about its axis (I = m r^2 / 2) brakes it at 2 mu_r g / r
// (196 rad/s^2 here), so the spin halves at t = w0 r / (4 mu_r g) and stops at twice that, and
// then stays stopped (the bound holds it, it does not turn it back).
TEST(RollingFriction, SpinOnAFloorStopsAtTheRateOfTheBound) {
  const double r = 0.005, mu_r = 0.05, w0 = 10.0, g = 9.81;
  const double t_half = w0 * r / (4.0 * mu_r * g);  // 25.5 ms
  struct Case {
    const char* integrator;
    const char* step;
  };
  for (const Case& c : {Case{"split_rotation", "auto"}, Case{"implicit_euler", "2.0e-4"},
                        Case{"implicit_euler", "2.0e-3"}}) {
    Scene s = rope_on_floor(r, mu_r, false, c.integrator, c.step, w0, 0.0);
    World& world = s.world;
    const Rod& rod = world.rods()[0];
    double vy = 0.0, spin = 0.0;
    const double t = time_to_fall(world, 3.0 * t_half, 0.5 * w0, [&] {
      rope_motion(rod, &vy, &spin);
      return spin;
    });
    rope_motion(rod, &vy, &spin);
    std::printf("%s h = %s: spin halved at %.2f ms (%.2f ms), %.3g rad/s after %.1f ms\n",
                c.integrator, c.step, 1e3 * t, 1e3 * t_half, spin, 1e3 * world.time());
    EXPECT_NEAR(t, t_half, 0.03 * t_half) << c.integrator << " " << c.step;
    EXPECT_LT(std::abs(spin), 0.01 * w0) << c.integrator << " " << c.step;
    for (int seg = 0; seg < rod.num_segments(); ++seg)
      EXPECT_LT(rod.angular_velocities()[seg].norm(), 0.05 * w0) << seg;
    EXPECT_LT(world.contacts()->stats().max_penetration, 0.01 * r);
  }
  // Without it the spin is kept.
  Scene s = rope_on_floor(r, 0.0, false, "split_rotation", "auto", w0, 0.0);
  while (s.world.time() < 3.0 * t_half) s.world.step();
  double vy = 0.0, spin = 0.0;
  rope_motion(s.world.rods()[0], &vy, &spin);
  EXPECT_GT(spin, 0.95 * w0);
}

// With friction at the surfaces a rope rolls; rolling resistance mu_r r m g decelerates a rolling
// cylinder (I = m r^2 / 2) at a = mu_r g / (1 + 1/2) = 2 mu_r g / 3, so from v0 it halves its
// speed at t = 3 v0 / (4 mu_r g) and stops at twice that.
TEST(RollingFriction, RollingRopeDeceleratesAsACylinder) {
  const double r = 0.005, mu_r = 0.05, v0 = 0.05, g = 9.81;
  const double t_half = 3.0 * v0 / (4.0 * mu_r * g);  // 76.5 ms
  for (bool implicit : {false, true}) {
    // Rolling to -y with a positive spin about x (the contact point at rest).
    Scene s = rope_on_floor(r, mu_r, true, implicit ? "implicit_euler" : "split_rotation",
                            implicit ? "5.0e-4" : "auto", v0 / r, -v0);
    World& world = s.world;
    const Rod& rod = world.rods()[0];
    double vy = 0.0, spin = 0.0;
    const double t = time_to_fall(world, 2.6 * t_half, 0.5 * v0, [&] {
      rope_motion(rod, &vy, &spin);
      return -vy;
    });
    rope_motion(rod, &vy, &spin);
    std::printf("implicit %d: speed halved at %.2f ms (%.2f ms); after %.0f ms v %.3g m/s\n",
                implicit, 1e3 * t, 1e3 * t_half, 1e3 * world.time(), vy);
    EXPECT_NEAR(t, t_half, 0.03 * t_half) << "implicit " << implicit;
    EXPECT_LT(std::abs(vy), 0.01 * v0) << "implicit " << implicit;
    EXPECT_LT(std::abs(spin) * r, 0.01 * v0) << "implicit " << implicit;
  }
}

// Two rods crossing, touching, spinning and sliding over each other without gravity or obstacles,
// with friction at the surfaces: rolling resistance acts as a couple (pr on one segment, -pr on
// the other), so the total angular momentum is kept to round-off while it changes the spins.
TEST(RollingFriction, RodRodCoupleKeepsAngularMomentum) {
  double spin_change[2] = {0.0, 0.0};
  for (double mu_r : {0.0, 0.5}) {
    char contact[96];
    std::snprintf(contact, sizeof contact,
                  "{friction: 0.5, surface_friction: true, rolling_friction: %.17g}", mu_r);
    Scene s = friction::crossing_rods(contact);
    World& world = s.world;
    const Rod& a = world.rods()[0];
    const double scale = friction::angular_momentum_scale(world);
    double worst = 0.0, couple = 0.0;
    const double spin0 = a.angular_velocities()[5].z();
    for (int k = 0; k < 200; ++k) {
      const Vec3 before = friction::angular_momentum(world);
      world.step();
      worst = std::max(worst, (friction::angular_momentum(world) - before).norm());
      for (const Contact& c : world.contacts()->contacts()) couple += c.pr.norm();
    }
    EXPECT_LT(worst, 1e-12 * scale) << "mu_r " << mu_r;
    if (mu_r > 0.0) {
      EXPECT_GT(couple, 0.0);
    }
    spin_change[mu_r > 0.0] = std::abs(a.angular_velocities()[5].z() - spin0);
  }
  // The couple brakes the spins beyond what surface friction alone does.
  EXPECT_GT(spin_change[1], spin_change[0] + 0.1);
}

TEST(RollingFriction, SceneKeyIsCheckedWithItsPath) {
  const std::string rod =
      "rods:\n  - {name: r, material: {preset: nylon_rope}, shape: {type: straight}}\n";
  EXPECT_EQ(parse_scene(rod + "contact: {rolling_friction: 0.05}\n").world.contact.rolling_friction,
            0.05);
  EXPECT_EQ(parse_scene(rod).world.contact.rolling_friction, ContactSettings().rolling_friction);
  for (const char* bad : {"-0.1", "1.5", ".nan", "lots"}) {
    try {
      parse_scene(rod + "contact: {rolling_friction: " + bad + "}\n");
      ADD_FAILURE() << "rolling_friction: " << bad << " accepted";
    } catch (const std::exception& e) {
      EXPECT_NE(std::string(e.what()).find("contact.rolling_friction"), std::string::npos)
          << e.what();
    }
  }
}

}  // namespace
}  // namespace corde
