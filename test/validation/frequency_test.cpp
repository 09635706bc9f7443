// V3 (docs/validation_references.md): natural frequencies of the example rod against beam theory,
// measured by FFT of a node's free vibration. Undamped, no gravity, amplitude <= 1e-3 L, >= 20
// periods of the lowest mode of each family, h = 0.5 of critical_time_step(). kappa = G A (shear
// coefficient 1).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <vector>

#include "corde_sim/stability/explicit_step_limit.h"
#include "dynamics_util.h"

namespace corde {
namespace {

using dyn::kPi;

constexpr double kLength = 1.0, kRadius = 0.01;

// Runs the rod undamped for `periods` periods of frequency f_low (Hz) at half the critical step
// and returns the series signal(rod) sampled about `rate` times per second.
template <class Signal>
std::vector<double> record(Rod* rod, double f_low, double periods, double rate, double* dt,
                           Signal&& signal) {
  const double h = 0.5 * critical_time_step(*rod);
  const long every = std::max(1L, std::lround(1.0 / (rate * h)));
  const long steps = std::lround(periods / f_low / h);
  *dt = every * h;
  std::vector<double> out;
  out.reserve(steps / every + 2);
  dyn::run(rod, h, steps, every, Vec3::Zero(), [&](double) {
    out.push_back(signal(*rod));
    return true;
  });
  return out;
}

// Free-free beam mode shape with eigenvalue beta L = bl, normalised to 2 at x = 0.
double free_free_shape(double bl, double xi) {
  const double s = (std::cosh(bl) - std::cos(bl)) / (std::sinh(bl) - std::sin(bl));
  const double b = bl * xi;
  return std::cosh(b) + std::cos(b) - s * (std::sinh(b) + std::sin(b));
}

constexpr double kBetaFreeFree[2] = {4.730041, 7.853205};
// The rod's continuum limit is a Timoshenko beam (shear stiffness kappa = G A, rotary inertia
// rho I), slightly below Euler-Bernoulli: omega_T/omega_EB - 1 for free-free modes 1 and 2, from
// scripts/timoshenko_frequencies.py (scipy shooting, independent of this code).
constexpr double kTimoshenkoFreeFree[2] = {-1.0777e-3, -3.0708e-3};

struct Bending {
  double ref[2], measured[2];
};

// Free-free bending: the sum of modes 1 and 2 (each 0.5e-3 L at the ends) as initial shape,
// frames along the chords, at rest; the end node's transverse displacement is analysed.
Bending free_free_bending(int elements) {
  Rod rod = dyn::straight_rod(dyn::example_material(), kRadius, kLength, elements);
  for (int i = 0; i <= elements; ++i) {
    const double xi = static_cast<double>(i) / elements;
    rod.positions()[i].z() =
        0.25e-3 * kLength *
        (free_free_shape(kBetaFreeFree[0], xi) + free_free_shape(kBetaFreeFree[1], xi));
  }
  dyn::align_frames_to_chords(&rod);
  Bending b;
  const double scale =
      std::sqrt(rod.section().bend / rod.section().mass_per_length) / (kLength * kLength);
  for (int k = 0; k < 2; ++k) b.ref[k] = kBetaFreeFree[k] * kBetaFreeFree[k] * scale / (2 * kPi);
  double dt = 0.0;
  const std::vector<double> z = record(&rod, b.ref[0], 20.0, 20.0 * b.ref[1], &dt,
                                       [](const Rod& r) { return r.positions().back().z(); });
  for (int k = 0; k < 2; ++k)
    b.measured[k] = dyn::peak_frequency(z, dt, 0.8 * b.ref[k], 1.2 * b.ref[k]);
  return b;
}

// Free-free axial mode 1: u = a cos(pi x / L), a = 1e-3 L; end node's axial displacement.
double free_free_axial(int elements, double* ref) {
  Rod rod = dyn::straight_rod(dyn::example_material(), kRadius, kLength, elements);
  for (int i = 0; i <= elements; ++i)
    rod.positions()[i].x() += 1e-3 * kLength * std::cos(kPi * i / elements);
  const double c = std::sqrt(rod.section().stretch / rod.section().mass_per_length);
  *ref = c / (2.0 * kLength);
  double dt = 0.0;
  const std::vector<double> u = record(&rod, *ref, 20.0, 20.0 * *ref, &dt,
                                       [](const Rod& r) { return r.positions().back().x(); });
  return dyn::peak_frequency(u, dt, 0.8 * *ref, 1.2 * *ref);
}

// Free-free torsion mode 1: segment twist a cos(pi s / L) at segment midpoints, a = 1e-3 rad;
// the first segment's rotation about its tangent.
double free_free_torsion(int elements, double* ref) {
  Rod rod = dyn::straight_rod(dyn::example_material(), kRadius, kLength, elements);
  const Quat q0 = rod.orientations()[0];
  for (int s = 0; s < elements; ++s) {
    const double angle = 1e-3 * std::cos(kPi * (s + 0.5) / elements);
    rod.orientations()[s] = q0 * Quat(Eigen::AngleAxisd(angle, Vec3::UnitZ()));
  }
  const double cs = std::sqrt(rod.section().twist / rod.section().inertia_twist);
  *ref = cs / (2.0 * kLength);
  double dt = 0.0;
  const std::vector<double> a = record(&rod, *ref, 20.0, 20.0 * *ref, &dt, [&](const Rod& r) {
    const Quat d = q0.conjugate() * r.orientations()[0];
    return 2.0 * std::atan2(d.z(), d.w());
  });
  return dyn::peak_frequency(a, dt, 0.8 * *ref, 1.2 * *ref);
}

TEST(PeakFrequency, RecoversSyntheticTonesToTenPpm) {
  // Two tones, 20 periods of the lower one, plus a drift the detrending must remove.
  const double f1 = 1.7805, f2 = 4.9081, dt = 0.01;
  std::vector<double> x;
  for (double t = 0.0; t < 20.0 / f1; t += dt)
    x.push_back(std::sin(2 * kPi * f1 * t + 0.3) + 0.3 * std::cos(2 * kPi * f2 * t) + 0.05 * t);
  EXPECT_NEAR(dyn::peak_frequency(x, dt, 1.4, 2.2) / f1, 1.0, 1e-5);
  EXPECT_NEAR(dyn::peak_frequency(x, dt, 4.0, 6.0) / f2, 1.0, 1e-5);
}

TEST(Frequencies, FreeFreeBendingModesOneAndTwo) {
  // Against Euler-Bernoulli (docs/validation_references.md, aim 1% at N = 50) and against the
  // Timoshenko limit, where the discretisation error shows its order (measured 1.98 for both
  // modes).
  const Bending coarse = free_free_bending(25), fine = free_free_bending(50);
  for (int k = 0; k < 2; ++k) {
    const double e25 = coarse.measured[k] / coarse.ref[k] - 1.0;
    const double e50 = fine.measured[k] / fine.ref[k] - 1.0;
    const double t = 1.0 + kTimoshenkoFreeFree[k];
    const double t25 = coarse.measured[k] / (t * coarse.ref[k]) - 1.0;
    const double t50 = fine.measured[k] / (t * fine.ref[k]) - 1.0;
    std::printf(
        "bending mode %d: EB %.6f Hz, N=25 %.6f (%+.3e), N=50 %.6f (%+.3e), order %.2f; "
        "vs Timoshenko %.6f Hz: %+.3e, %+.3e, order %.2f\n",
        k + 1, fine.ref[k], coarse.measured[k], e25, fine.measured[k], e50,
        dyn::observed_order(e25, e50), t * fine.ref[k], t25, t50, dyn::observed_order(t25, t50));
    EXPECT_LT(std::abs(e50), 0.01) << "mode " << k + 1;
    EXPECT_NEAR(dyn::observed_order(t25, t50), 2.0, 0.4) << "mode " << k + 1;
  }
}

TEST(Frequencies, FreeFreeAxialModeOne) {
  double ref = 0.0;
  const double f25 = free_free_axial(25, &ref), f50 = free_free_axial(50, &ref);
  const double e25 = f25 / ref - 1.0, e50 = f50 / ref - 1.0;
  std::printf("axial mode 1: ref %.6f Hz, N=25 %.6f (%+.3e), N=50 %.6f (%+.3e), order %.2f\n", ref,
              f25, e25, f50, e50, dyn::observed_order(e25, e50));
  EXPECT_LT(std::abs(e50), 0.005);
  // The lumped chain's mode is exactly (2N/pi) sin(pi/(2N)) c/(2L): second order.
  EXPECT_NEAR(dyn::observed_order(e25, e50), 2.0, 0.4);
}

TEST(Frequencies, FreeFreeTorsionModeOne) {
  double ref = 0.0;
  const double f25 = free_free_torsion(25, &ref), f50 = free_free_torsion(50, &ref);
  const double e25 = f25 / ref - 1.0, e50 = f50 / ref - 1.0;
  std::printf("torsion mode 1: ref %.6f Hz, N=25 %.6f (%+.3e), N=50 %.6f (%+.3e), order %.2f\n",
              ref, f25, e25, f50, e50, dyn::observed_order(e25, e50));
  EXPECT_LT(std::abs(e50), 0.01);
  EXPECT_NEAR(dyn::observed_order(e25, e50), 2.0, 0.4);
}

}  // namespace
}  // namespace corde
