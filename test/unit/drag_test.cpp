// Air drag: a rod falling broadside or lengthwise reaches the terminal velocity where drag
// balances its weight, for linear and quadratic drag; a swinging rope loses energy.
#include <gtest/gtest.h>

#include <cmath>

#include "corde_sim/rod_shape.h"
#include "corde_sim/world.h"

namespace corde {
namespace {

constexpr double kPi = 3.14159265358979323846;

World falling_rod(const Vec3& direction, const Drag& drag) {
  Material m;
  m.youngs_modulus = m.stretch_modulus = 1e7;
  m.shear_modulus = 1e7 / 3.0;
  m.density = 1000.0;
  const double r = 0.005;
  m.kappa = m.shear_modulus * kPi * r * r;
  RodSpec spec;
  spec.elements = 10;
  spec.section = make_section(m, r);
  spec.shape.direction = direction;
  spec.shape.length = 0.5;
  World w;
  w.time_step = 5e-5;
  w.add_rod(build_rod(spec));
  w.rods()[0].set_drag(drag);
  return w;
}

// Mean node velocity after `seconds` of falling.
Vec3 velocity_after(World* w, double seconds) {
  w->step(static_cast<int>(std::lround(seconds / w->time_step)));
  Vec3 v = Vec3::Zero();
  for (const Vec3& vi : w->rods()[0].velocities()) v += vi;
  return v / w->rods()[0].num_nodes();
}

TEST(Drag, TerminalVelocities) {
  const double mu = 1000.0 * kPi * 0.005 * 0.005, g = 9.81;
  {  // broadside, linear: v = mu g / c_n (time constant mu / c_n = 0.079 s: 25 of them)
    Drag d;
    d.linear_normal = 1.0;
    World w = falling_rod(Vec3::UnitX(), d);
    EXPECT_NEAR(velocity_after(&w, 2.0).z(), -mu * g / d.linear_normal, 1e-9);
  }
  {  // broadside, quadratic: v = sqrt(mu g / q_n) (air: rho_f C_d r = 1.2 * 1.2 * 0.005)
    Drag d;
    d.quadratic_normal = 1.2 * 1.2 * 0.005;
    World w = falling_rod(Vec3::UnitX(), d);
    const double v_t = std::sqrt(mu * g / d.quadratic_normal);  // 7.3 m/s
    EXPECT_NEAR(velocity_after(&w, 20.0).z(), -v_t, 1e-6 * v_t);
  }
  {  // lengthwise, the tangential coefficients act and the normal ones do not
    Drag d;
    d.linear_tangential = 0.5;
    d.linear_normal = 100.0;
    World w = falling_rod(Vec3(0, 0, -1), d);
    const Vec3 v = velocity_after(&w, 4.0);  // 25 time constants mu / c_t
    EXPECT_NEAR(v.z(), -mu * g / d.linear_tangential, 1e-9);
    EXPECT_LT(v.head<2>().norm(), 1e-12);
  }
}

TEST(Drag, RefusesNegativeCoefficients) {
  World w = falling_rod(Vec3::UnitX(), Drag());
  Drag d;
  d.quadratic_normal = -1.0;
  EXPECT_THROW(w.rods()[0].set_drag(d), std::invalid_argument);
  d.quadratic_normal = NAN;
  EXPECT_THROW(w.rods()[0].set_drag(d), std::invalid_argument);
}

TEST(Drag, SwingingRopeSlowsDown) {
  // A rod pinned at one end swinging as a pendulum: internal friction spares rigid motion, so
  // only drag takes its energy.
  Drag d;
  d.quadratic_normal = 1.2 * 1.2 * 0.005;
  World w = falling_rod(Vec3::UnitX(), d);
  NodeDrive pin;
  pin.origin = w.rods()[0].positions()[0];
  w.rods()[0].add_node_drive(pin);
  World still_air = falling_rod(Vec3::UnitX(), Drag());
  still_air.rods()[0].add_node_drive(pin);
  w.step(40000);  // 2 s: several swings
  still_air.step(40000);
  const double e = w.energies().kinetic() + w.energies().total.gravity;
  const double e0 = still_air.energies().kinetic() + still_air.energies().total.gravity;
  EXPECT_LT(e, e0 - 1e-3);
}

}  // namespace
}  // namespace corde
