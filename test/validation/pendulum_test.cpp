// V5 (docs/validation_references.md): a very stiff rod pinned at one end (node 0 fixed,
// segment 0 free) swings under gravity like a rigid compound pendulum. Reference:
// T = T0 (2/pi) K(sin(theta0/2)) with T0 = 2 pi sqrt(2L/(3g)) times
// sqrt(I_discrete / I_continuum) = sqrt(1 + 1/(2N^2) + 3r^2/(4L^2)): lumped node masses (the
// reference's factor) and the segments' own rotational inertia (physical, rho pi r^4/4 per
// length; 3e-4 here). Aim 0.3%; measured errors are about 1e-5.
//
// Stiffness: L = 1, r = 2 cm, rho = 1000, E = E_s = 1e10, G = E/3, kappa = G A. Just stiff enough
// to be rigid to ~1e-4: the largest stretch strain of the 90 degree swing is 2.4e-6 and the
// largest bending deviation from the straight line 6.8e-5 L (with E = 1e9 it is 6.8e-4 L and the
// period still agrees to 4e-5). h = 0.8 of critical_time_step() (about 8 us at N = 10).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <vector>

#include "corde_sim/stability/explicit_step_limit.h"
#include "dynamics_util.h"

namespace corde {
namespace {

using dyn::kPi;

constexpr double kLength = 1.0, kRadius = 0.02, kG = 9.81;

// Complete elliptic integral of the first kind K(k) by the arithmetic-geometric mean.
double elliptic_k(double k) {
  double a = 1.0, b = std::sqrt(1.0 - k * k);
  for (int i = 0; i < 40 && std::abs(a - b) > 1e-16 * a; ++i) {
    const double an = 0.5 * (a + b);
    b = std::sqrt(a * b);
    a = an;
  }
  return kPi / (2.0 * a);
}

// T / T0 of a pendulum released from rest at theta0 (rad).
double amplitude_factor(double theta0) { return 2.0 / kPi * elliptic_k(std::sin(0.5 * theta0)); }

double reference_period(int elements, double theta0) {
  const double t0 = 2.0 * kPi * std::sqrt(2.0 * kLength / (3.0 * kG));
  const double inertia =
      1.0 + 1.0 / (2.0 * elements * elements) + 0.75 * kRadius * kRadius / (kLength * kLength);
  return t0 * std::sqrt(inertia) * amplitude_factor(theta0);
}

struct Swing {
  double period = 0.0;      // between the first and third zero crossings of the angle
  double max_strain = 0.0;  // largest |stretch strain| seen
};

Swing swing(int elements, double theta0) {
  Material m;
  m.youngs_modulus = m.stretch_modulus = 1e10;
  m.shear_modulus = m.youngs_modulus / 3.0;
  m.density = 1000.0;
  m.kappa = m.shear_modulus * kPi * kRadius * kRadius;
  Rod rod = dyn::straight_rod(m, kRadius, kLength, elements,
                              Vec3(std::sin(theta0), 0.0, -std::cos(theta0)), Vec3::UnitY());
  rod.add_node_drive(NodeDrive{});  // node 0 fixed at the origin; segment 0 turns freely
  const double h = 0.8 * critical_time_step(rod);
  const long steps = std::lround(1.3 * reference_period(elements, theta0) / h);
  std::vector<double> crossings;
  double prev = theta0, t_prev = 0.0;
  Swing out;
  dyn::run(&rod, h, steps, 1, Vec3(0.0, 0.0, -kG), [&](double t) {
    // Angle of the centre of mass from the downward vertical (node 0 sits at the origin).
    const Vec3 c = rod.center_of_mass();
    const double theta = std::atan2(c.x(), -c.z());
    if (t > 0.0 && (theta < 0.0) != (prev < 0.0))
      crossings.push_back(t_prev + (t - t_prev) * prev / (prev - theta));
    prev = theta;
    t_prev = t;
    const std::vector<Vec3>& x = rod.positions();
    for (int s = 0; s < elements; ++s)
      out.max_strain = std::max(out.max_strain,
                                std::abs((x[s + 1] - x[s]).norm() / rod.rest_lengths()[s] - 1.0));
    return true;
  });
  if (crossings.size() >= 3) out.period = crossings[2] - crossings[0];
  return out;
}

TEST(Pendulum, EllipticFactorsMatchValidationTable) {
  EXPECT_NEAR(amplitude_factor(kPi / 6.0), 1.017409, 1e-6);
  EXPECT_NEAR(amplitude_factor(kPi / 3.0), 1.073182, 1e-6);
  EXPECT_NEAR(amplitude_factor(kPi / 2.0), 1.180341, 1e-6);
}

TEST(Pendulum, SmallAmplitudeWithLumpedMassFactor) {
  // At N = 5 the lumped-mass factor is 1.0100: without it the period would be off by 1%, so the
  // 0.3% tolerance checks that the discrete inertia is the one predicted.
  const double theta0 = kPi / 180.0;  // 1 degree: elliptic factor 1.000019
  for (int n : {5, 10}) {
    const Swing s = swing(n, theta0);
    const double ref = reference_period(n, theta0);
    std::printf(
        "pendulum small (1 deg), N=%d: ref %.6f s, measured %.6f s, error %+.2e, "
        "max strain %.1e\n",
        n, ref, s.period, s.period / ref - 1.0, s.max_strain);
    EXPECT_NEAR(s.period / ref, 1.0, 3e-3) << "N = " << n;
    EXPECT_LT(s.max_strain, 1e-4);
  }
}

TEST(Pendulum, LargeAmplitudeRatios) {
  const int n = 10;
  const double t_small = reference_period(n, 0.0);
  for (double deg : {30.0, 60.0, 90.0}) {
    const double theta0 = deg * kPi / 180.0;
    const Swing s = swing(n, theta0);
    const double ratio = s.period / t_small, ref = amplitude_factor(theta0);
    std::printf(
        "pendulum %2.0f deg, N=%d: T/T0 ref %.6f, measured %.6f, error %+.2e, "
        "max strain %.1e\n",
        deg, n, ref, ratio, ratio / ref - 1.0, s.max_strain);
    EXPECT_NEAR(ratio / ref, 1.0, 3e-3) << deg << " degrees";
    EXPECT_LT(s.max_strain, 1e-4);
  }
}

}  // namespace
}  // namespace corde
