// Friction at the contact point on the surfaces (ContactSettings::surface_friction): a rope
// spinning about its axis on a floor is braked into rolling as a cylinder is, a rod-rod contact
// keeps the total angular momentum.
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

// The lying rope of friction_util.h on a floor with friction mu, friction at the surfaces, no
// rolling resistance, spinning at w0 with its nodes at rest.
Scene spinning_rope(double r, double mu, double w0, bool implicit) {
  return friction::lying_rope(r, mu, "{surface_friction: true, rolling_friction: 0}",
                              implicit ? "implicit_euler" : "split_rotation",
                              implicit ? "2.0e-4" : "auto", w0, 0.0);
}

// A cylinder of radius r spinning at w0 about its axis on a plane with friction mu slides until
// t = w0 r / (3 mu g) (friction mu m g speeds it up sideways and brakes the spin, I = m r^2 / 2)
// and then rolls at v = w0 r / 3, w = w0 / 3. The rope does the same, explicit and implicit.
TEST(SurfaceFriction, SpinningRopeOnFloorTurnsIntoRolling) {
  const double r = 0.005, mu = 0.5, w0 = 60.0, g = 9.81;
  const double t_roll = w0 * r / (3.0 * mu * g), v_roll = w0 * r / 3.0;  // 20.4 ms, 0.1 m/s
  for (bool implicit : {false, true}) {
    Scene s = spinning_rope(r, mu, w0, implicit);
    World& world = s.world;
    const Rod& rod = world.rods()[0];
    // The time the contact stops slipping: the slip speed v_y + r w (the contact point's) falls
    // below 1 % of its start.
    double t_stick = -1.0, vy = 0.0, spin = 0.0;
    while (world.time() < 3.0 * t_roll) {
      world.step();
      rope_motion(rod, &vy, &spin);
      if (t_stick < 0.0 && std::abs(vy + r * spin) < 0.01 * r * w0) t_stick = world.time();
    }
    // Measured: t_stick 20.30 ms explicit, 20.20 ms implicit (20.39 ms); v 0.1000 m/s both.
    EXPECT_NEAR(t_stick, t_roll, 0.05 * t_roll) << "implicit " << implicit;
    // Rolling to the -y side (the contact point slid to +y), without slipping.
    EXPECT_NEAR(-vy, v_roll, 0.02 * v_roll) << "implicit " << implicit;
    EXPECT_NEAR(spin, w0 / 3.0, 0.02 * w0 / 3.0) << "implicit " << implicit;
    EXPECT_LT(std::abs(vy + r * spin), 0.01 * r * w0) << "implicit " << implicit;
    EXPECT_LT(world.contacts()->stats().max_penetration, 0.01 * r);
  }
  // Friction at the axis (the model before) has no moment: the spin is kept and nothing rolls.
  Scene s = spinning_rope(r, mu, w0, false);
  s.world.contact.surface_friction = false;
  while (s.world.time() < 3.0 * t_roll) s.world.step();
  double vy = 0.0, spin = 0.0;
  rope_motion(s.world.rods()[0], &vy, &spin);
  EXPECT_GT(spin, 0.95 * w0);
  EXPECT_LT(std::abs(vy), 1e-3 * v_roll);
}

// Two rods crossing, touching, spinning and sliding over each other without gravity or
// obstacles: the contact's impulses (at one point on both surfaces) keep the total angular
// momentum, the nodes' x x m v and the segments' spin, to round-off over each step, while friction
// changes the spins. At the axes (no moment) the friction's couple (the axes' distance times the
// tangential impulse) would change it.
TEST(SurfaceFriction, RodRodContactKeepsAngularMomentum) {
  for (bool surface : {true, false}) {
    Scene s = friction::crossing_rods(surface ? "{friction: 0.5, surface_friction: true}"
                                              : "{friction: 0.5, surface_friction: false}");
    World& world = s.world;
    const Rod& a = world.rods()[0];
    const double scale = friction::angular_momentum_scale(world);
    double worst = 0.0, tangential = 0.0, spin_a0 = a.angular_velocities()[5].z();
    for (int k = 0; k < 200; ++k) {
      const Vec3 before = friction::angular_momentum(world);
      world.step();
      worst = std::max(worst, (friction::angular_momentum(world) - before).norm());
      for (const Contact& c : world.contacts()->contacts()) tangential += c.pt.norm();
    }
    ASSERT_GT(tangential, 0.0);
    if (surface) {
      EXPECT_LT(worst, 1e-12 * scale);
      EXPECT_GT(std::abs(a.angular_velocities()[5].z() - spin_a0), 0.1);
    } else {
      EXPECT_GT(worst, 1e-9 * scale);  // the couple of friction at the axes
    }
  }
}

}  // namespace
}  // namespace corde
