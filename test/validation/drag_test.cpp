// Air drag: a rod falling broadside or lengthwise reaches the terminal velocity where drag
// balances its weight, for linear and quadratic drag; a swinging rope loses energy.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "corde_sim/rod/rod_shape.h"
#include "corde_sim/scene/scene.h"
#include "corde_sim/world/world.h"

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

// A body in air reaches its terminal velocity: a free straight rod falling broadside, built from a
// scene (drag from the air's density and the cylinder's drag coefficient, or a linear
// coefficient), whose centre of mass falls at sqrt(m g / (q_n L)) or m g / (c_n L).
TEST(Drag, SceneRodFallingBroadsideReachesTerminalVelocity) {
  const std::string rod_text =
      "gravity: [0, 0, -9.81]\n"
      "time_step: auto\n"
      "rods:\n"
      "  - elements: 10\n"
      "    radius: 0.005\n"
      "    material: {E: 1.0e7, nu: 0.5, rho: 1000}\n"
      "    shape: {type: straight, direction: [1, 0, 0], length: 0.5}\n";
  const double m = 1000.0 * kPi * 0.005 * 0.005 * 0.5, L = 0.5, g = 9.81;
  struct Case {
    const char* drag;
    double terminal, seconds;
  } cases[] = {
      // q_n = rho_air C_d r = 1.2 * 1.2 * 0.005: v = 10.4 m/s, time constant v / g = 1.06 s.
      {"    drag: {fluid_density: 1.2, drag_coefficient: 1.2}\n",
       std::sqrt(m * g / (1.2 * 1.2 * 0.005 * L)), 6.0},
      // c_n = 0.5 N s/m^2: v = 1.54 m/s, time constant m / (c_n L) = 0.16 s.
      {"    drag: {linear_normal: 0.5}\n", m * g / (0.5 * L), 2.0},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.drag);
    Scene s = parse_scene(rod_text + c.drag);
    const Rod& rod = s.world.rods()[0];
    double mass = 0.0;
    for (double mi : rod.node_masses()) mass += mi;
    EXPECT_NEAR(mass, m, 1e-12);
    s.world.step(static_cast<int>(std::ceil(c.seconds / s.world.time_step)));
    const Vec3 v = rod.linear_momentum() / mass;  // velocity of the centre of mass
    EXPECT_NEAR(v.z(), -c.terminal, 0.01 * c.terminal);
    EXPECT_LT(v.head<2>().norm(), 1e-6 * c.terminal);
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
