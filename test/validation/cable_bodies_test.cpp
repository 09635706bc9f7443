// What a real cable carries besides its section (docs/scene_format.md, "Cable bodies"): point
// masses at nodes, a plug's rotary inertia on an end segment, density ranges and gravity ramped in,
// against analytic references: the compound pendulum (rod + point mass + body inertia), a
// cantilever with a tip mass (P L^3 / 3B + q L^4 / 8B and their shear parts), the centre of mass
// and the hanging tension of a non-uniform rod, free fall under a ramp, and the conservation of
// momentum.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <vector>

#include "corde_sim/stability/explicit_step_limit.h"
#include "corde_sim/statics/statics.h"
#include "corde_sim/world/world.h"
#include "dynamics_util.h"
#include "validation_util.h"

namespace corde {
namespace {

using dyn::kPi;

constexpr double kG = 9.81;

// The stiff rod of the V5 pendulum (pendulum_test.cpp): rigid to about 1e-4 in its swing.
Material stiff_material(double radius) {
  Material m;
  m.youngs_modulus = m.stretch_modulus = 1e10;
  m.shear_modulus = m.youngs_modulus / 3.0;
  m.density = 1000.0;
  m.kappa = m.shear_modulus * kPi * radius * radius;
  return m;
}

// A compound pendulum: a rod of length L pinned at node 0, a point mass M at its tip and a body of
// inertia J (across the axis) on its end segment. Small swings: T = 2 pi sqrt(I / (g (m L/2 +
// M L))) with I = m L^2/3 (1 + 1/(2N^2) + 3r^2/(4L^2)) + M L^2 + J (the bracket: the lumped
// masses' and the segments' own inertia, as in V5).
struct PendulumCase {
  int elements = 10;
  double length = 1.0, radius = 0.02, tip_mass = 0.0, tip_inertia = 0.0;
  double offset = 0.0;  // the tip body's centre of mass this far beyond the tip, along the rod
};

double pendulum_reference(const PendulumCase& c) {
  const double m = 1000.0 * kPi * c.radius * c.radius * c.length;
  const int n = c.elements;
  const double rod =
      m * c.length * c.length / 3.0 *
      (1.0 + 1.0 / (2.0 * n * n) + 0.75 * c.radius * c.radius / (c.length * c.length));
  // An offset body: its weight at L + a; its inertia about the tip node by the parallel axis,
  // M a^2, the model's block-diagonal mass (docs/scene_format.md, "Cable bodies"; a rigid body
  // would have M (L + a)^2 in all, 2 M L a more).
  const double inertia =
      rod + c.tip_mass * c.length * c.length + c.tip_inertia + c.tip_mass * c.offset * c.offset;
  const double moment = kG * (0.5 * m * c.length + c.tip_mass * (c.length + c.offset));
  return 2.0 * kPi * std::sqrt(inertia / moment);
}

Rod pendulum_rod(const PendulumCase& c, double theta0) {
  Rod rod = dyn::straight_rod(stiff_material(c.radius), c.radius, c.length, c.elements,
                              Vec3(std::sin(theta0), 0.0, -std::cos(theta0)), Vec3::UnitY());
  rod.add_node_drive(NodeDrive{});  // node 0 fixed at the origin; segment 0 turns freely
  if (c.tip_mass > 0.0) rod.add_node_mass(c.elements, c.tip_mass);
  if (c.tip_inertia > 0.0)
    rod.add_segment_inertia(c.elements - 1, Vec3(c.tip_inertia, c.tip_inertia, 0.0));
  if (c.offset > 0.0) {  // as the scene's masses[i].offset builds it
    const double parallel = c.tip_mass * c.offset * c.offset;
    rod.add_segment_inertia(c.elements - 1, Vec3(parallel, parallel, 0.0));
    rod.add_mass_offset(c.elements, c.tip_mass, Vec3(0.0, 0.0, c.offset));
  }
  return rod;
}

// The period between the first and third zero crossings of the tip's angle from the vertical.
// implicit: the world's BDF2 at step h; else the rod's explicit split rotation at 0.8 of its limit.
double pendulum_period(const PendulumCase& c, bool implicit, double h = 0.0) {
  const double theta0 = kPi / 180.0;
  World world;
  world.gravity = Vec3(0.0, 0.0, -kG);
  world.add_rod(pendulum_rod(c, theta0));
  Rod& rod = world.rods()[0];
  if (implicit) {
    world.integrator = Integrator::kBdf2;
    world.time_step = h;
  } else {
    world.time_step = 0.8 * critical_time_step(rod);
  }
  const long steps = std::lround(1.3 * pendulum_reference(c) / world.time_step);
  std::vector<double> crossings;
  double prev = theta0, t_prev = 0.0;
  for (long k = 0; k < steps && crossings.size() < 3; ++k) {
    world.step();
    const Vec3 tip = rod.positions()[c.elements];
    const double theta = std::atan2(tip.x(), -tip.z()), t = world.time();
    if ((theta < 0.0) != (prev < 0.0))
      crossings.push_back(t_prev + (t - t_prev) * prev / (prev - theta));
    prev = theta;
    t_prev = t;
  }
  return crossings.size() >= 3 ? crossings[2] - crossings[0] : NAN;
}

// A plug as heavy as the rod doubles its period's lever arm; the plug's inertia is 5% of the
// rod's. Aim 0.3% as V5 (the elliptic factor of 1 degree, 1.9e-5, is left in the error).
TEST(CableBodies, TipMassPendulumMatchesCompoundPendulum) {
  PendulumCase base;
  const double rod_mass = 1000.0 * kPi * base.radius * base.radius * base.length;
  PendulumCase mass = base, body = base;
  mass.tip_mass = rod_mass;
  body.tip_mass = rod_mass;
  body.tip_inertia = 0.05 * rod_mass / 3.0;
  for (const PendulumCase& c : {base, mass, body}) {
    const double ref = pendulum_reference(c);
    const double explicit_t = pendulum_period(c, false);
    const double implicit_t = pendulum_period(c, true, 1e-3);
    std::printf(
        "tip-mass pendulum M = %.4g kg, J = %.3g kg m^2: ref %.6f s, split_rotation %.6f s "
        "(%+.2e), bdf2 h = 1 ms %.6f s (%+.2e)\n",
        c.tip_mass, c.tip_inertia, ref, explicit_t, explicit_t / ref - 1.0, implicit_t,
        implicit_t / ref - 1.0);
    EXPECT_NEAR(explicit_t / ref, 1.0, 3e-3);
    EXPECT_NEAR(implicit_t / ref, 1.0, 3e-3);
  }
  // The tip mass changes the period by far more than the tolerance: the test sees it.
  EXPECT_GT(std::abs(pendulum_reference(mass) / pendulum_reference(base) - 1.0), 0.05);
  EXPECT_GT(std::abs(pendulum_reference(body) / pendulum_reference(mass) - 1.0), 0.005);
}

// A cantilever with a tip mass M under gravity is the cantilever with the dead force M g at its
// tip (to the statics' tolerance), and beam theory gives its deflection:
// P L^3 / (3B) + P L / kappa + q L^4 / (8B) + q L^2 / (2 kappa), P = M g, q = mu g.
TEST(CableBodies, CantileverWithTipMass) {
  const Material m = val::example_material(1.0, 1e11);
  const Section sec = make_section(m, val::kRadius);
  const double q = sec.mass_per_length * kG, tip_mass = 0.5 * sec.mass_per_length;  // half the rod
  const double p = tip_mass * kG, l = val::kLength;
  const double ref = p * l * l * l / (3.0 * sec.bend) + p * l / sec.kappa +
                     q * l * l * l * l / (8.0 * sec.bend) + q * l * l / (2.0 * sec.kappa);
  const Vec3 g(0.0, 0.0, -kG);
  for (int n : {20, 40}) {
    Rod with_mass = val::straight_rod(m, n);
    val::clamp_start(&with_mass, val::Clamp::kGhost);
    with_mass.add_node_mass(n, tip_mass);
    Rod with_load = val::straight_rod(m, n);
    val::clamp_start(&with_load, val::Clamp::kGhost);
    Load load;
    load.index = n;
    load.value = Vec3(0.0, 0.0, -p);
    with_load.add_load(load);
    ASSERT_TRUE(solve_statics(with_mass, g, 0.0).converged);
    ASSERT_TRUE(solve_statics(with_load, g, 0.0).converged);
    const double d_mass = -with_mass.positions()[n].z(), d_load = -with_load.positions()[n].z();
    std::printf("cantilever tip mass N=%d: ref %.6e m, tip mass %.6e m (%+.2e), dead load %.6e m\n",
                n, ref, d_mass, d_mass / ref - 1.0, d_load);
    EXPECT_NEAR(d_mass / d_load, 1.0, 1e-8);
    EXPECT_NEAR(d_mass / ref, 1.0, 0.01);  // the ghost clamp's V1 aim at N = 20
    // The clamp holds the rod, the tip mass and nothing else.
    with_mass.set_static_reactions(0.0, g);
    const double weight = (sec.mass_per_length * l + tip_mass) * kG;
    EXPECT_NEAR(with_mass.node_drive(0)->reaction.z(), weight, 1e-6 * weight);
  }
}

// A rod with a heavier stretch (3 rho over [0.25, 0.5] L, on nodes): its lumped masses have the
// continuum's centre of mass, and hanging from its top at rest each segment's tension is the weight
// below it (a soft K_s makes it visible as stretch).
TEST(CableBodies, NonUniformDensityCentreOfMassAndHangingTension) {
  const Material m = val::example_material();  // strain about 1.5e-3 under the rod's weight
  const int n = 20;
  Rod rod = dyn::straight_rod(m, val::kRadius, 1.0, n, Vec3(0.0, 0.0, -1.0), Vec3::UnitX());
  std::vector<double> scale(n, 1.0);
  for (int s = 5; s < 10; ++s) scale[s] = 3.0;
  rod.set_segment_mass_scale(scale);
  const double mu = rod.section().mass_per_length;
  const double mass = mu * (0.75 + 3.0 * 0.25);
  const double moment = mu * (0.5 * 1.0 + 2.0 * 0.5 * (0.5 * 0.5 - 0.25 * 0.25));  // int rho x
  double total = 0.0;
  for (double mi : rod.node_masses()) total += mi;
  EXPECT_NEAR(total, mass, 1e-14);
  EXPECT_NEAR(-rod.center_of_mass().z(), moment / mass, 1e-14);
  EXPECT_GT(std::abs(-rod.center_of_mass().z() - 0.5), 0.04);  // not the uniform rod's
  std::printf("non-uniform rod: centre of mass %.12f m below the top, analytic %.12f m\n",
              -rod.center_of_mass().z(), moment / mass);

  rod.add_node_drive(NodeDrive{});
  const Vec3 g(0.0, 0.0, -kG);
  ASSERT_TRUE(solve_statics(rod, g, 0.0).converged);
  double worst = 0.0;
  for (int s = 0; s < n; ++s) {
    double below = 0.0;
    for (int i = s + 1; i <= n; ++i) below += rod.node_masses()[i] * kG;
    worst = std::max(worst, std::abs(rod.tension(s) / below - 1.0));
  }
  std::printf("non-uniform rod hanging: worst tension error %.2e\n", worst);
  EXPECT_LT(worst, 1e-6);
}

// Free fall under gravity ramped in over T: the velocity is g t^2 / (2T) until T and g (t - T/2)
// after (to the explicit step's first order in h); gravity_at is exact at and after T.
TEST(CableBodies, RampedGravityReachesItsValueAtTheRampTime) {
  World world;
  world.gravity = Vec3(0.0, 0.0, -kG);
  world.gravity_ramp = 0.5;
  EXPECT_EQ(world.gravity_at(0.5), world.gravity);
  EXPECT_EQ(world.gravity_at(2.0), world.gravity);
  EXPECT_EQ(world.gravity_at(0.0), Vec3::Zero());
  EXPECT_NEAR(world.gravity_at(0.25).z(), -0.5 * kG, 1e-15);
  world.add_rod(dyn::straight_rod(dyn::example_material(), 0.01, 1.0, 10));
  world.rods()[0].add_node_mass(10, 0.2);
  world.time_step = 1e-4;
  const Rod& rod = world.rods()[0];
  auto com_velocity = [&] {
    return rod.linear_momentum().z() / [&] {
      double m = 0.0;
      for (double mi : rod.node_masses()) m += mi;
      return m;
    }();
  };
  world.step(2500);  // t = 0.25
  const double v_half = com_velocity(), ref_half = -kG * 0.25 * 0.25 / (2.0 * 0.5);
  world.step(7500);  // t = 1
  const double v_end = com_velocity(), ref_end = -kG * (1.0 - 0.25);
  std::printf("ramped gravity free fall: v(0.25) %.6f (ref %.6f), v(1) %.6f (ref %.6f) m/s\n",
              v_half, ref_half, v_end, ref_end);
  EXPECT_NEAR(v_half / ref_half, 1.0, 2e-3);  // first order: h / t = 4e-4 relative
  EXPECT_NEAR(v_end / ref_end, 1.0, 1e-3);
}

// Without gravity and supports a rod with point masses and a plug keeps its linear momentum to
// round-off under the explicit integrators and to the Newton tolerance under the implicit ones,
// and its angular momentum under the split rotation.
TEST(CableBodies, MomentumConservedWithPointMassesAndPlug) {
  for (Integrator integrator : {Integrator::kSplitRotation, Integrator::kSemiImplicitEuler,
                                Integrator::kImplicitEuler, Integrator::kBdf2}) {
    World world;
    world.gravity = Vec3::Zero();
    world.integrator = integrator;
    Rod& rod = world.add_rod(dyn::straight_rod(dyn::example_material(), 0.01, 1.0, 20));
    rod.add_node_mass(7, 0.05);
    rod.add_node_mass(20, 0.1);
    rod.add_segment_inertia(19, Vec3(2e-5, 2e-5, 4e-6));
    std::vector<double> scale(20, 1.0);
    scale[3] = 4.0;
    rod.set_segment_mass_scale(scale);
    for (int i = 0; i < rod.num_nodes(); ++i)
      rod.velocities()[i] = Vec3(0.1 * std::sin(i), 0.2 * std::cos(3.0 * i), 0.05 * i);
    for (int s = 0; s < rod.num_segments(); ++s)
      rod.angular_velocities()[s] = Vec3(std::cos(s), 0.3, 0.5 * std::sin(2.0 * s));
    world.time_step = is_implicit(integrator) ? 1e-3 : 0.8 * critical_time_step(rod);
    const Vec3 p0 = rod.linear_momentum(), l0 = rod.angular_momentum();
    world.step(500);
    const double dp = (rod.linear_momentum() - p0).norm() / p0.norm();
    const double dl = (rod.angular_momentum() - l0).norm() / l0.norm();
    std::printf("momentum with point masses, %s: |dp|/|p| %.1e, |dL|/|L| %.1e\n",
                integrator_name(integrator), dp, dl);
    // Explicit: round-off (2e-16 measured); implicit: the Newton solve's tolerance (bdf2 2e-12).
    EXPECT_LT(dp, is_implicit(integrator) ? 1e-10 : 1e-14) << integrator_name(integrator);
    if (integrator == Integrator::kSplitRotation) {
      EXPECT_LT(dl, 1e-10);
    }
  }
}

// The explicit step limit follows the masses: a lighter stretch lowers it, and the rod runs stable
// at 0.9 of the new limit (its energy stays bounded), while at the old limit it would blow up.
TEST(CableBodies, ExplicitStepLimitFollowsMasses) {
  const int n = 20;
  Rod uniform = dyn::straight_rod(dyn::example_material(), 0.01, 1.0, n);
  Rod light = uniform;
  std::vector<double> scale(n, 1.0);
  for (int s = 8; s < 12; ++s) scale[s] = 0.05;
  light.set_segment_mass_scale(scale);
  Rod heavy = uniform;
  heavy.add_node_mass(n, 1.0);
  const double h_uniform = critical_time_step(uniform), h_light = critical_time_step(light);
  std::printf("explicit limit: uniform %.3e s, light stretch %.3e s, with a tip mass %.3e s\n",
              h_uniform, h_light, critical_time_step(heavy));
  EXPECT_LT(h_light, 0.5 * h_uniform);
  EXPECT_GE(critical_time_step(heavy), 0.999 * h_uniform);
  auto energy_after = [&](double h) {
    Rod rod = light;
    rod.add_node_drive(NodeDrive{});
    for (int i = 1; i <= n; ++i) rod.velocities()[i] = Vec3(0.0, 0.0, 0.01 * std::sin(i));
    const double e0 = rod.energies(Vec3::Zero()).kinetic();
    for (int k = 0; k < 20000 && rod.finite(); ++k) rod.step(k * h, h, Vec3::Zero());
    const Energies e = rod.energies(Vec3::Zero());
    return rod.finite() ? (e.kinetic() + e.elastic()) / e0 : INFINITY;
  };
  EXPECT_LT(energy_after(0.9 * h_light), 10.0);
  EXPECT_GT(energy_after(std::min(0.9 * h_uniform, 3.0 * h_light)), 1e3);
}

// A plug whose centre of mass lies a = 0.2 L beyond the tip (masses[i].offset): its weight acts
// there and turns the end segment, its inertia about the tip is J + M a^2. The small-angle period
// against the compound pendulum of that model (moment g (m L/2 + M (L + a))), under the explicit
// split rotation and BDF2; the offset changes the period by far more than the tolerance.
TEST(CableBodies, OffsetPlugPendulumPeriod) {
  PendulumCase c;
  c.tip_mass = 1000.0 * kPi * c.radius * c.radius * c.length;
  c.tip_inertia = 0.05 * c.tip_mass / 3.0;
  c.offset = 0.2 * c.length;
  PendulumCase no_offset = c;
  no_offset.offset = 0.0;
  const double ref = pendulum_reference(c);
  const double explicit_t = pendulum_period(c, false);
  const double implicit_t = pendulum_period(c, true, 1e-3);
  // The rod's mass equals the plug's here.
  const double moment = kG * c.tip_mass * (0.5 * c.length + c.length + c.offset);
  const double inertia = moment * std::pow(ref / (2.0 * kPi), 2);
  const double rigid =
      2.0 * kPi * std::sqrt((inertia + 2.0 * c.tip_mass * c.length * c.offset) / moment);
  std::printf(
      "offset plug pendulum a = %.3g m: ref %.6f s, split_rotation %.6f s (%+.2e), bdf2 "
      "%.6f s (%+.2e); without the offset %.6f s; a rigid body (2 M L a more inertia) "
      "%.6f s\n",
      c.offset, ref, explicit_t, explicit_t / ref - 1.0, implicit_t, implicit_t / ref - 1.0,
      pendulum_reference(no_offset), rigid);
  EXPECT_NEAR(explicit_t / ref, 1.0, 3e-3);
  EXPECT_NEAR(implicit_t / ref, 1.0, 3e-3);
  EXPECT_GT(std::abs(ref / pendulum_reference(no_offset) - 1.0), 0.02);
}

// The same pendulum swinging 30 degrees without damping under the explicit split rotation: the
// total energy (gravity at the offset centre of mass, the parallel-axis rotary energy) stays
// within 1 % of what the offset alone moves, M g a (1 - cos 30 deg), over a period.
TEST(CableBodies, OffsetPlugPendulumKeepsItsEnergy) {
  PendulumCase c;
  c.tip_mass = 1000.0 * kPi * c.radius * c.radius * c.length;
  c.offset = 0.2 * c.length;
  const double theta0 = kPi / 6.0;
  World world;
  world.gravity = Vec3(0.0, 0.0, -kG);
  world.add_rod(pendulum_rod(c, theta0));
  Rod& rod = world.rods()[0];
  world.time_step = 0.8 * critical_time_step(rod);
  const auto total = [&] {
    const Energies e = rod.energies(world.gravity);
    return e.kinetic() + e.elastic() + e.gravity;
  };
  const double e0 = total();
  double worst = 0.0;
  const long steps = std::lround(1.1 * pendulum_reference(c) / world.time_step);
  for (long k = 0; k < steps; ++k) {
    world.step();
    worst = std::max(worst, std::abs(total() - e0));
  }
  const double offset_part = c.tip_mass * kG * c.offset * (1.0 - std::cos(theta0));
  std::printf("offset plug pendulum at 30 deg: energy drift %.3e J, the offset's share %.3e J\n",
              worst, offset_part);
  EXPECT_LT(worst, 0.01 * offset_part);
}

// A horizontal cantilever carrying a plug whose centre of mass lies a beyond the tip along the
// tangent: the tip load P = M g and the moment P a give P L^3/(3B) + P L/kappa + P a L^2/(2B)
// + q L^4/(8B) + q L^2/(2 kappa) (small deflections; the moment's arm shortens by O(slope^2)).
// The error falls with N at second order, as the point-mass cantilever's does
// (CantileverWithTipMass); the moment's share of the deflection, 7.9 %, is far above it.
TEST(CableBodies, CantileverWithOffsetPlug) {
  const Material m = val::example_material(1.0, 1e11);
  const Section sec = make_section(m, val::kRadius);
  const double q = sec.mass_per_length * kG, tip_mass = 0.5 * sec.mass_per_length;
  const double p = tip_mass * kG, l = val::kLength, a = 0.1 * l;
  const double moment_part = p * a * l * l / (2.0 * sec.bend);
  const double ref = p * l * l * l / (3.0 * sec.bend) + p * l / sec.kappa + moment_part +
                     q * l * l * l * l / (8.0 * sec.bend) + q * l * l / (2.0 * sec.kappa);
  const Vec3 g(0.0, 0.0, -kG);
  double prev = 0.0;
  for (int n : {10, 20, 40}) {
    Rod rod = val::straight_rod(m, n);
    val::clamp_start(&rod, val::Clamp::kGhost);
    ASSERT_NEAR(rod.orientations()[n - 1].toRotationMatrix().col(2).x(), 1.0, 1e-12);
    rod.add_node_mass(n, tip_mass);
    rod.add_segment_inertia(n - 1, Vec3(tip_mass * a * a, tip_mass * a * a, 0.0));
    rod.add_mass_offset(n, tip_mass, Vec3(0.0, 0.0, a));
    ASSERT_TRUE(solve_statics(rod, g, 0.0).converged);
    const double d = -rod.positions()[n].z(), err = std::abs(d / ref - 1.0);
    std::printf("cantilever offset plug N=%d: ref %.6e m, %.6e m (%+.2e)%s\n", n, ref, d,
                d / ref - 1.0,
                prev > 0.0 ? (" order " + std::to_string(std::log2(prev / err))).c_str() : "");
    // Measured: 6.6e-3, 1.6e-3, 4.1e-4, second order as the point-mass cantilever.
    EXPECT_LT(err, n == 10 ? 0.01 : n == 20 ? 3e-3 : 1e-3);
    if (prev > 0.0) {
      EXPECT_GT(std::log2(prev / err), 1.8);
    }
    prev = err;
    // The clamp carries the weights and the moment of the plug's weight about the clamp.
    rod.set_static_reactions(0.0, g);
    const double weight = (sec.mass_per_length * l + tip_mass) * kG;
    EXPECT_NEAR(rod.node_drive(0)->reaction.z(), weight, 1e-6 * weight);
  }
  EXPECT_GT(moment_part / ref, 0.05);  // 7.9 % of the deflection
}

}  // namespace
}  // namespace corde
