// V4 (docs/validation_references.md): Euler buckling loads from the static Hessian, and the
// post-buckling branch of a pinned-pinned elastica under imposed end shortening, solved as statics.
// Pinned = node fixed, segment free (no ghost frame). Planar problems (normal y): this removes
// the rigid rotation of a pinned-pinned rod about its chord, a zero mode. The references are
// inextensible and unshearable: E_s and kappa are 1e3 times the example rod's (their effect on
// P_cr is ~P_cr/kappa = 1e-6 relative).
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <cstdio>
#include <vector>

#include "corde_sim/statics/static_hessian.h"
#include "corde_sim/statics/statics.h"
#include "validation_util.h"

namespace corde {
namespace {

using val::kPi;

enum class Ends { kPinned, kClampedGhost, kClampedNatural };

const char* ends_name(Ends e) {
  switch (e) {
    case Ends::kPinned:
      return "pinned-pinned";
    case Ends::kClampedGhost:
      return "clamped-clamped (ghost)";
    case Ends::kClampedNatural:
      return "clamped-clamped (natural)";
  }
  return "";
}

StaticOptions planar() {
  StaticOptions o;
  o.plane_normal = Vec3::UnitY();
  return o;
}

// A straight rod whose far end is held at x = L - delta; returns the lowest eigenvalue of the
// static Hessian (N/m) at the compressed equilibrium and the axial end force in *force.
double lowest_eigenvalue(int n, Ends ends, double delta, double* force) {
  Rod rod = val::straight_rod(val::example_material(1e3), n);
  if (ends == Ends::kPinned) {
    NodeDrive a;
    a.node = 0;
    rod.add_node_drive(a);
  } else {
    const val::Clamp c = ends == Ends::kClampedGhost ? val::Clamp::kGhost : val::Clamp::kNatural;
    val::clamp_start(&rod, c);
    val::clamp_end(&rod, c);
  }
  NodeDrive b;
  b.node = n;
  b.origin = Vec3(val::kLength - delta, 0.0, 0.0);
  rod.add_node_drive(b);
  const StaticResult res = solve_statics(rod, Vec3::Zero(), 0.0, planar());
  EXPECT_TRUE(res.converged);
  rod.compute_forces(0.0, Vec3::Zero());
  *force = rod.forces()[n].x();  // the compressed rod pushes its end outwards
  const Eigen::MatrixXd h(static_hessian(rod, Vec3::Zero(), 0.0, planar()));
  return Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(h, Eigen::EigenvaluesOnly).eigenvalues()(0);
}

// The end force at which the lowest eigenvalue crosses zero, by secant iteration on the end
// shortening starting from 0.9 and 1.1 of the reference load.
double critical_load(int n, Ends ends, double reference) {
  const double ks = make_section(val::example_material(1e3), val::kRadius).stretch;
  double d0 = 0.9 * reference / ks, d1 = 1.1 * reference / ks, p0, p1;
  double l0 = lowest_eigenvalue(n, ends, d0, &p0), l1 = lowest_eigenvalue(n, ends, d1, &p1);
  for (int it = 0; it < 20 && std::abs(d1 - d0) > 1e-9 * d1; ++it) {
    const double d2 = d1 - l1 * (d1 - d0) / (l1 - l0);
    d0 = d1;
    l0 = l1;
    p0 = p1;
    d1 = d2;
    l1 = lowest_eigenvalue(n, ends, d1, &p1);
  }
  return p1;
}

// Critical loads at N = 25, 50, 100. Pinned-pinned pi^2 B/L^2: within 0.1% at N = 50, second
// order. Clamped-clamped 4 pi^2 B/L^2 with ghost frames: within 0.5% at N = 50, second order;
// with natural clamps: first order, Richardson (50, 100) within 0.5%.
TEST(Buckling, V4CriticalLoads) {
  const double b = make_section(val::example_material(), val::kRadius).bend;
  for (Ends ends : {Ends::kPinned, Ends::kClampedGhost, Ends::kClampedNatural}) {
    const double ref = (ends == Ends::kPinned ? 1.0 : 4.0) * kPi * kPi * b;
    std::vector<double> p, err;
    for (int n : {25, 50, 100}) {
      p.push_back(critical_load(n, ends, ref));
      err.push_back(p.back() / ref - 1.0);
      std::printf("V4 %-26s N=%3d P_cr ref %.5f N measured %.5f N rel.error %+.3e order %s\n",
                  ends_name(ends), n, ref, p.back(), err.back(),
                  err.size() > 1
                      ? std::to_string(val::observed_order(err[err.size() - 2], err.back()))
                            .substr(0, 5)
                            .c_str()
                      : "-");
    }
    const double order = val::observed_order(err[1], err[2]);
    if (ends == Ends::kPinned) {
      EXPECT_LT(std::abs(err[1]), 1e-3);
      EXPECT_NEAR(order, 2.0, 0.2);
    } else if (ends == Ends::kClampedGhost) {
      EXPECT_LT(std::abs(err[1]), 5e-3);
      EXPECT_NEAR(order, 2.0, 0.3);
    } else {
      EXPECT_NEAR(order, 1.0, 0.2);
      const double rich = val::richardson1(p[1], p[2]);
      std::printf("V4 clamped-clamped (natural) Richardson(50, 100): %.5f N, rel.error %+.3e\n",
                  rich, rich / ref - 1.0);
      EXPECT_LT(std::abs(rich / ref - 1.0), 5e-3);
    }
  }
}

// Post-buckling of the pinned-pinned elastica, N = 50: the far end is moved to the table's
// X = L (1 - shortening) and the statics are solved from a guess whose tangent angle is
// theta0 cos(pi s / L) (the linear buckling mode, bulging towards +z, with the table's end slope
// theta0; only a starting point). Measured: end force P / P_cr, mid-span deflection / L and the
// end slope (segment 0's tangent, O(l^2) from the end since the pinned end has no moment).
// Aim: all within 2%.
TEST(Buckling, V4PostBuckling) {
  const int n = 50;
  const double l = val::kLength / n;
  struct Row {
    double slope_deg, load, shortening, deflection;
  };
  const Row rows[] = {{20, 1.01540, 0.03027, 0.10971},
                      {30, 1.03512, 0.06757, 0.16195},
                      {45, 1.08154, 0.14934, 0.23426},
                      {60, 1.15172, 0.25898, 0.29660},
                      {90, 1.39320, 0.54305, 0.38138}};
  for (const Row& row : rows) {
    Rod rod = val::straight_rod(val::example_material(1e3), n);
    const double p_cr = kPi * kPi * rod.section().bend / (val::kLength * val::kLength);
    const double theta0 = row.slope_deg * kPi / 180.0;
    const Quat straight = rod.orientations()[0];
    for (int s = 0; s < n; ++s) {
      const double th = theta0 * std::cos(kPi * (s + 0.5) / n);
      rod.positions()[s + 1] = rod.positions()[s] + l * Vec3(std::cos(th), 0.0, std::sin(th));
      rod.orientations()[s] = Quat(Eigen::AngleAxisd(-th, Vec3::UnitY())) * straight;
    }
    NodeDrive a;
    a.node = 0;
    rod.add_node_drive(a);
    NodeDrive b;
    b.node = n;
    b.origin = Vec3(val::kLength * (1.0 - row.shortening), 0.0, 0.0);
    rod.add_node_drive(b);
    const StaticResult res = solve_statics(rod, Vec3::Zero(), 0.0, planar());
    EXPECT_TRUE(res.converged);
    rod.compute_forces(0.0, Vec3::Zero());
    const double load = rod.forces()[n].x() / p_cr;
    const double deflection = rod.positions()[n / 2].z() / val::kLength;
    const Vec3 d3 = rod.orientations()[0] * Vec3::UnitZ();
    const double slope = std::atan2(d3.z(), d3.x()) * 180.0 / kPi;
    std::printf(
        "V4 post-buckling N=%d slope %2.0f deg: P/P_cr %.5f (ref %.5f, %+.2e), mid-span %.5f "
        "(ref %.5f, %+.2e), end slope %.3f deg (%+.2e); %d Newton iterations\n",
        n, row.slope_deg, load, row.load, load / row.load - 1.0, deflection, row.deflection,
        deflection / row.deflection - 1.0, slope, slope / row.slope_deg - 1.0, res.iterations);
    EXPECT_NEAR(load / row.load, 1.0, 0.02);
    EXPECT_NEAR(deflection / row.deflection, 1.0, 0.02);
    EXPECT_NEAR(slope / row.slope_deg, 1.0, 0.02);
  }
}

}  // namespace
}  // namespace corde
