// Discrete strains (darboux(), eq. 25) of rods with known curvature and torsion, their order of
// accuracy, and their independence of the quaternions' signs.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "corde_sim/rod/rod.h"
#include "validation_util.h"

namespace corde {
namespace {

Section example_section() { return make_section(val::example_material(), val::kRadius); }

// Helix of radius a and rise c per radian sampled at arc-length steps h = S/n: curvature
// a/(a^2+c^2), torsion c/(a^2+c^2). Frames are the Frenet frames (d1 = normal, d2 = binormal,
// d3 = tangent) at the segments' mid arc length, so u = (0, kappa, tau).
Rod frenet_helix(int n, double a, double c, double length) {
  const double w = std::sqrt(a * a + c * c);
  auto point = [&](double s) { return Vec3(a * std::cos(s / w), a * std::sin(s / w), c * s / w); };
  std::vector<Vec3> x(n + 1);
  std::vector<Quat> q(n);
  const double h = length / n;
  for (int i = 0; i <= n; ++i) x[i] = point(i * h);
  for (int s = 0; s < n; ++s) {
    const double phi = (s + 0.5) * h / w;
    Eigen::Matrix3d r;
    r.col(2) = Vec3(-a * std::sin(phi), a * std::cos(phi), c) / w;  // tangent
    r.col(0) = Vec3(-std::cos(phi), -std::sin(phi), 0.0);           // principal normal
    r.col(1) = r.col(2).cross(r.col(0));                            // binormal
    q[s] = Quat(r);
  }
  return Rod("helix", x, q, example_section());
}

// Frames of a constant body Darboux vector u: q(s) = exp(s u / 2); nodes by the midpoint rule
// x_{i+1} = x_i + h d3(s_{i+1/2}), so every segment has rest length h exactly.
Rod darboux_rod(int n, const Vec3& u, double length) {
  const double h = length / n;
  std::vector<Vec3> x(n + 1, Vec3::Zero());
  std::vector<Quat> q(n);
  for (int s = 0; s < n; ++s) {
    const double sm = (s + 0.5) * h;
    q[s] = Quat(Eigen::AngleAxisd(sm * u.norm(), u.normalized()));
    x[s + 1] = x[s] + h * (q[s] * Vec3::UnitZ());
  }
  return Rod("darboux", x, q, example_section());
}

Vec3 element_strain(const Rod& rod, int j) {
  const double rest = 0.5 * (rod.rest_lengths()[j] + rod.rest_lengths()[j + 1]);
  return darboux(rod.orientations()[j], rod.orientations()[j + 1], rest);
}

double max_strain_error(const Rod& rod, const Vec3& exact) {
  double e = 0.0;
  for (int j = 0; j + 1 < rod.num_segments(); ++j)
    e = std::max(e, (element_strain(rod, j) - exact).norm());
  return e;
}

// Frenet helix with kappa = 4.706, tau = 1.176 (a = 0.2, c = 0.05), about one turn (S = 1.3 m):
// the strains are (0, kappa, tau) up to O(l^2): error below 1e-3 |u| at N = 40, observed order
// 2 +- 0.1 from N = 20 and 40.
TEST(Strain, FrenetHelixGivesCurvatureAndTorsion) {
  const double a = 0.2, c = 0.05, w2 = a * a + c * c;
  const Vec3 exact(0.0, a / w2, c / w2);
  const double e20 = max_strain_error(frenet_helix(20, a, c, 1.3), exact);
  const double e40 = max_strain_error(frenet_helix(40, a, c, 1.3), exact);
  const double order = val::observed_order(e20, e40);
  std::printf(
      "Frenet helix: kappa %.4f tau %.4f; max strain error %.3e (N=20), %.3e (N=40), "
      "order %.3f\n",
      exact.y(), exact.z(), e20, e40, order);
  EXPECT_LT(e40, 1e-3 * exact.norm());
  EXPECT_NEAR(order, 2.0, 0.1);
}

// Constant Darboux vector u = (1.5, -2, 3) (bending about both directors and twist): the
// discrete strain is (2/h) sin(h|u|/2) u/|u| exactly (to 1e-12), an O(h^2) error with observed
// order 2 +- 0.05 from N = 20 and 40.
TEST(Strain, ConstantDarbouxFrames) {
  const Vec3 u(1.5, -2.0, 3.0);
  double err[2];
  int k = 0;
  for (int n : {20, 40}) {
    const Rod rod = darboux_rod(n, u, 1.0);
    const double h = 1.0 / n;
    const Vec3 closed = (2.0 / h) * std::sin(0.5 * h * u.norm()) * u.normalized();
    for (int j = 0; j + 1 < n; ++j) EXPECT_LT((element_strain(rod, j) - closed).norm(), 1e-12);
    err[k++] = max_strain_error(rod, u);
  }
  const double order = val::observed_order(err[0], err[1]);
  std::printf(
      "constant Darboux u=(1.5,-2,3): max strain error %.3e (N=20), %.3e (N=40), order "
      "%.3f\n",
      err[0], err[1], order);
  EXPECT_NEAR(order, 2.0, 0.05);
}

// q and -q are one rotation: flipping the sign of every other quaternion changes no strain, no
// energy and no force or torque, with zero rest strain and with intrinsic curvature and twist
// (rest strains of a helix, on a perturbed state). Tolerance 1e-12 relative.
TEST(Strain, QuaternionSignFlipsChangeNothing) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> uni(-1.0, 1.0);
  for (bool intrinsic : {false, true}) {
    Rod rod = frenet_helix(16, 0.2, 0.05, 1.3);
    if (intrinsic) {
      rod.set_rest_strains_from_state();
      for (auto& x : rod.positions()) x += 0.003 * Vec3(uni(rng), uni(rng), uni(rng));
      for (auto& q : rod.orientations())
        q = (q * Quat(Eigen::AngleAxisd(0.1 * uni(rng),
                                        Vec3(uni(rng), uni(rng), uni(rng)).normalized())))
                .normalized();
    }
    Rod flipped = rod;
    for (int s = 1; s < rod.num_segments(); s += 2) flipped.orientations()[s].coeffs() *= -1.0;
    // Rest strains taken from a flipped state are the same too.
    if (intrinsic) {
      Rod a = frenet_helix(16, 0.2, 0.05, 1.3), b = a;
      for (int s = 0; s < b.num_segments(); s += 2) b.orientations()[s].coeffs() *= -1.0;
      a.set_rest_strains_from_state();
      b.set_rest_strains_from_state();
      for (size_t j = 0; j < a.rest_strains().size(); ++j)
        EXPECT_LT((a.rest_strains()[j] - b.rest_strains()[j]).norm(), 1e-12);
    }
    for (int j = 0; j + 1 < rod.num_segments(); ++j)
      EXPECT_LT((element_strain(rod, j) - element_strain(flipped, j)).norm(), 1e-12);
    const Energies e0 = rod.energies(Vec3::Zero()), e1 = flipped.energies(Vec3::Zero());
    std::printf("sign flips (%s): bend/twist energy %.12e vs %.12e J\n",
                intrinsic ? "intrinsic strain" : "no rest strain", e0.bend_twist, e1.bend_twist);
    EXPECT_GT(e0.bend_twist, 0.0);
    EXPECT_NEAR(e1.bend_twist / e0.bend_twist, 1.0, 1e-12);
    EXPECT_NEAR(e1.elastic() / e0.elastic(), 1.0, 1e-12);
    rod.compute_forces(0.0, Vec3::Zero());
    flipped.compute_forces(0.0, Vec3::Zero());
    double fmax = 0.0, tmax = 0.0;
    for (int i = 0; i < rod.num_nodes(); ++i) fmax = std::max(fmax, rod.forces()[i].norm());
    for (int s = 0; s < rod.num_segments(); ++s) tmax = std::max(tmax, rod.torques()[s].norm());
    for (int i = 0; i < rod.num_nodes(); ++i)
      EXPECT_LT((rod.forces()[i] - flipped.forces()[i]).norm(), 1e-12 * fmax);
    for (int s = 0; s < rod.num_segments(); ++s)
      EXPECT_LT((rod.torques()[s] - flipped.torques()[s]).norm(), 1e-12 * tmax);
  }
}

// The helix's bending energy with zero rest strain tends to (S/2)(B kappa^2 + C tau^2) over the
// interior elements' span (N - 1) l, at second order (chord rest lengths and the strain both
// carry O(l^2)): within 2e-3 at N = 40, observed order 2 +- 0.1 from N = 20 and 40.
TEST(Strain, HelixEnergy) {
  const double a = 0.2, c = 0.05, w2 = a * a + c * c, kappa = a / w2, tau = c / w2;
  const Section sec = example_section();
  double err[2];
  int k = 0;
  for (int n : {20, 40}) {
    const Rod rod = frenet_helix(n, a, c, 1.3);
    const double span = 1.3 * (n - 1) / n;
    const double exact = 0.5 * span * (sec.bend * kappa * kappa + sec.twist * tau * tau);
    const double e = rod.energies(Vec3::Zero()).bend_twist;
    err[k++] = e / exact - 1.0;
    std::printf("helix N=%d bend/twist energy %.6e J, continuum %.6e J, rel.error %+.3e\n", n, e,
                exact, e / exact - 1.0);
  }
  EXPECT_LT(std::abs(err[1]), 2e-3);
  EXPECT_NEAR(val::observed_order(err[0], err[1]), 2.0, 0.1);
}

}  // namespace
}  // namespace corde
