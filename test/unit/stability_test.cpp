// critical_time_step() against the measured stability edge of the integrator.
//
// A run is called unstable when the largest total energy over its last 1000 of 10^4 steps exceeds
// 10x the largest over its first 1000. Comparing maxima (not the initial energy) matters: near
// the edge semi-implicit Euler keeps a modified energy, and the true energy of a stable mode with
// h omega -> 2 swings by (1 + h omega/2)/(1 - h omega/2), which a "10x the initial energy" test
// reads as instability 1-8% below the edge. With this criterion the prediction matched bisected
// edges to 0.1% (undamped, N = 10..80, kappa x0.1..x10) and to 3.4% with internal friction.
// Here each case checks that 0.97x the prediction is stable and 1.03x is not.
#include "corde_sim/stability.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>

#include "corde_sim/rod_shape.h"

namespace corde {
namespace {

constexpr double kPi = 3.14159265358979323846;

struct Case {
  int elements;
  double kappa_scale;          // kappa = scale * G A
  double tau;                  // Kelvin-Voigt retardation time of gamma_t, gamma_r (s)
  bool clamped;                // ghost clamp at the start, node fixed at the end
  double stretch_scale = 1.0;  // E_s = scale * E (braided ropes: E_s >> E)
};

// The example rod of docs/validation_references.md: L = 1, r = 1 cm, rho = 1000,
// E = E_s = 1e7, G = E/3.
Rod make_rod(const Case& c) {
  const double r = 0.01, area = kPi * r * r, e = 1e7;
  Material m;
  m.youngs_modulus = e;
  m.shear_modulus = e / 3.0;
  m.stretch_modulus = c.stretch_scale * e;
  m.density = 1000.0;
  m.kappa = c.kappa_scale * m.shear_modulus * area;
  m.gamma_t = c.tau * m.stretch_modulus * area;
  m.gamma_r = c.tau * e * area * r * r / 4.0;
  RodSpec spec;
  spec.elements = c.elements;
  spec.section = make_section(m, r);
  Rod rod = build_rod(spec);
  if (c.clamped) {
    NodeDrive fix;
    rod.add_node_drive(fix);
    fix.node = c.elements;
    fix.origin = rod.positions().back();
    rod.add_node_drive(fix);
    rod.ghost_start().active = true;
    rod.ghost_start().frame = rod.orientations()[0];
  }
  // Random perturbation of 1e-6 on every degree of freedom.
  std::mt19937 gen(7);
  std::uniform_real_distribution<double> u(-1e-6, 1e-6);
  auto rnd = [&] { return Vec3(u(gen), u(gen), u(gen)); };
  for (auto& x : rod.positions()) x += rnd();
  for (auto& v : rod.velocities()) v = rnd();
  for (auto& q : rod.orientations())
    q = (q * Quat(Eigen::AngleAxisd(1e-6, rnd().normalized()))).normalized();
  for (auto& w : rod.angular_velocities()) w = rnd();
  return rod;
}

bool grows(const Case& c, double h) {
  Rod rod = make_rod(c);
  const Vec3 g = Vec3::Zero();
  double first = 0.0, last = 0.0;
  for (int i = 0; i < 10000; ++i) {
    rod.step(i * h, h, g);
    const Energies e = rod.energies(g);
    const double total = e.elastic() + e.kinetic();
    if (!(total < 1e30)) return true;
    if (i < 1000) first = std::max(first, total);
    if (i >= 9000) last = std::max(last, total);
  }
  return last > 10.0 * first;
}

class StabilityEdge : public ::testing::TestWithParam<Case> {};

TEST_P(StabilityEdge, PredictionBracketsMeasuredEdge) {
  const Case c = GetParam();
  const StabilityEstimate est = estimate_stability(make_rod(c));
  ASSERT_GT(est.time_step, 0.0);
  EXPECT_FALSE(grows(c, 0.97 * est.time_step)) << "limiting " << est.limiting;
  EXPECT_TRUE(grows(c, 1.03 * est.time_step)) << "limiting " << est.limiting;
}

INSTANTIATE_TEST_SUITE_P(
    Rods, StabilityEdge,
    ::testing::Values(Case{10, 1.0, 0.0, false},     // bending-shear limited, free ends
                      Case{40, 1.0, 0.0, false},     //
                      Case{20, 10.0, 0.0, false},    // stiff penalty: free-end modes dominate
                      Case{20, 1.0, 0.0, true},      // ghost clamp and fixed node
                      Case{40, 0.1, 1e-3, false},    // stretch limited by its friction
                      Case{20, 1.0, 1e-2, false}));  // heavily damped stretch

// V7 exactly as docs/validation_references.md states it: a run is unstable if its total energy
// exceeds 10x the initial energy within 10^4 steps (checked every 10 steps, stopping at the first
// excess). The edge is bisected 7 times inside [0.5, 1.5] x the prediction (resolution 0.8% of it).
// Near the edge a stable top mode's energy swings by (1 + h w/2)/(1 - h w/2), so this criterion
// reads the edge a little early: measured/predicted slightly below 1 is expected, aim 0.7 .. 1.05.
bool exceeds_tenfold(const Case& c, double h) {
  Rod rod = make_rod(c);
  const Vec3 g = Vec3::Zero();
  const Energies e0 = rod.energies(g);
  const double initial = e0.elastic() + e0.kinetic();
  for (int i = 0; i < 10000; ++i) {
    rod.step(i * h, h, g);
    if ((i + 1) % 10 != 0) continue;
    const Energies e = rod.energies(g);
    const double total = e.elastic() + e.kinetic();
    if (!(total <= 10.0 * initial)) return true;  // also catches NaN
  }
  return false;
}

// The continuum estimates of docs/model.md, independent of stability.cpp: 2/omega_max over
// stretch 2c/l, twist 2c_s/l, frame bending 2c/l, centreline bending 4 sqrt(B/(rho A))/l^2 and
// the coupling penalty 2 sqrt(kappa/(rho A)) sqrt(1/l^2 + 1/r^2).
double continuum_estimate(const Rod& rod) {
  const Section& s = rod.section();
  const double l = rod.rest_lengths()[0], r = s.radius, mu = s.mass_per_length;
  const double c = std::sqrt(s.stretch / mu), cs = std::sqrt(s.twist / s.inertia_twist);
  const double cb = std::sqrt(s.bend / s.inertia_bend);
  const double w =
      std::max({2.0 * c / l, 2.0 * cs / l, 2.0 * cb / l, 4.0 * std::sqrt(s.bend / mu) / (l * l),
                2.0 * std::sqrt(s.kappa / mu) * std::sqrt(1.0 / (l * l) + 1.0 / (r * r))});
  return 2.0 / w;
}

class StabilityEdgeV7 : public ::testing::TestWithParam<Case> {};

TEST_P(StabilityEdgeV7, BisectedEdgeOverPredictionInRange) {
  const Case c = GetParam();
  const Rod rod = make_rod(c);
  const StabilityEstimate est = estimate_stability(rod);
  const double pred = est.time_step;
  double lo = 0.5 * pred, hi = 1.5 * pred;
  ASSERT_FALSE(exceeds_tenfold(c, lo));
  ASSERT_TRUE(exceeds_tenfold(c, hi));
  for (int it = 0; it < 7; ++it) {
    const double mid = 0.5 * (lo + hi);
    (exceeds_tenfold(c, mid) ? hi : lo) = mid;
  }
  const double measured = 0.5 * (lo + hi), local = continuum_estimate(rod);
  std::printf(
      "V7 N=%d kappa=%.1fGA E_s=%.0fE: measured %.4e s, library %.4e s (%s), ratio %.3f; "
      "continuum estimate %.4e s, ratio %.3f\n",
      c.elements, c.kappa_scale, c.stretch_scale, measured, pred, est.limiting.c_str(),
      measured / pred, local, measured / local);
  if (c.kappa_scale > 1.0) {
    EXPECT_EQ(est.limiting, "bending-shear");
  }
  if (c.stretch_scale > 1.0) {
    EXPECT_EQ(est.limiting, "stretch");
  }
  EXPECT_GE(measured / pred, 0.7);
  EXPECT_LE(measured / pred, 1.05);
}

INSTANTIATE_TEST_SUITE_P(
    FreeFreeUndamped, StabilityEdgeV7,
    ::testing::Values(Case{10, 1.0, 0.0, false}, Case{20, 1.0, 0.0, false},
                      Case{40, 1.0, 0.0, false}, Case{80, 1.0, 0.0, false},
                      Case{20, 10.0, 0.0, false},         // coupling penalty dominates
                      Case{40, 1.0, 0.0, false, 10.0}));  // stretch dominates (E_s = 10 E)

TEST(Stability, ContinuumLimitsForLongElements) {
  // With l >> r and a soft penalty the families approach the continuum formulas of docs/model.md:
  // stretch 2c/l, twist 2 c_s/l (interior of a free chain: slightly below).
  const Rod rod = make_rod({10, 1e-3, 0.0, false});
  const StabilityEstimate est = estimate_stability(rod);
  const double l = 0.1, c = std::sqrt(1e7 / 1000.0), cs = std::sqrt(1e7 / 3.0 / 1000.0);
  EXPECT_NEAR(est.stretch, l / c, 1e-9);
  EXPECT_GT(est.twist, l / cs);
  EXPECT_LT(est.twist, l / cs * 1.02);
  EXPECT_EQ(critical_time_step(rod), est.time_step);
}

TEST(Stability, RetardationTimeShrinksStep) {
  const double undamped = critical_time_step(make_rod({40, 0.1, 0.0, false}));
  const double damped = critical_time_step(make_rod({40, 0.1, 1e-3, false}));
  EXPECT_LT(damped, 0.5 * undamped);
}

}  // namespace
}  // namespace corde
