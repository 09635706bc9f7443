// Finite-difference checks of every energy gradient and of the torque conversion.
#include <gtest/gtest.h>

#include <random>

#include "corde_sim/model/element_energies.h"
#include "corde_sim/rod/rod.h"
#include "corde_sim/rod/rod_shape.h"

namespace corde {
namespace {

std::mt19937 rng(42);
double uni(double a, double b) { return std::uniform_real_distribution<double>(a, b)(rng); }
Vec3 rand_vec(double s) { return Vec3(uni(-s, s), uni(-s, s), uni(-s, s)); }
Quat rand_quat() {
  return Quat(Eigen::Vector4d(uni(-1, 1), uni(-1, 1), uni(-1, 1), uni(-1, 1))).normalized();
}
Quat near(const Quat& q, double s) {
  return Quat(q.coeffs() + Eigen::Vector4d::Random() * s).normalized();
}

double rel_err(const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
  return (a - b).norm() / std::max(1e-300, std::max(a.norm(), b.norm()));
}

template <class F>
Eigen::VectorXd fd_grad(F f, Eigen::VectorXd x, double h) {
  Eigen::VectorXd g(x.size());
  for (int i = 0; i < x.size(); ++i) {
    Eigen::VectorXd xp = x, xm = x, xp2 = x, xm2 = x;
    xp(i) += h;
    xm(i) -= h;
    xp2(i) += 2 * h;
    xm2(i) -= 2 * h;
    g(i) = (8 * (f(xp) - f(xm)) - (f(xp2) - f(xm2))) / (12 * h);  // fourth order
  }
  return g;
}

Quat from4(const Eigen::VectorXd& v, int o) { return Quat(v(o + 3), v(o), v(o + 1), v(o + 2)); }

TEST(EnergyGradient, Stretch) {
  for (int trial = 0; trial < 20; ++trial) {
    const Vec3 dr = rand_vec(0.1) + Vec3(0.05, 0, 0);
    const double rest = uni(0.02, 0.1), ks = uni(10, 1000);
    Vec3 g;
    stretch_energy(dr, rest, ks, &g);
    auto f = [&](const Eigen::VectorXd& x) { return stretch_energy(x, rest, ks, nullptr); };
    EXPECT_LT(rel_err(g, fd_grad(f, dr, 1e-5)), 1e-6);
  }
}

TEST(EnergyGradient, Coupling) {
  for (int trial = 0; trial < 20; ++trial) {
    const Quat q = rand_quat();
    const Vec3 dr = 0.05 * (q * Vec3::UnitZ()) + rand_vec(0.02);
    const double rest = 0.05, kappa = uni(1, 100);
    Vec3 gr;
    Vec4 gq;
    coupling_energy(dr, q, rest, kappa, &gr, &gq);
    auto fr = [&](const Eigen::VectorXd& x) {
      return coupling_energy(x, q, rest, kappa, nullptr, nullptr);
    };
    auto fq = [&](const Eigen::VectorXd& x) {
      return coupling_energy(dr, from4(x, 0), rest, kappa, nullptr, nullptr);
    };
    EXPECT_LT(rel_err(gr, fd_grad(fr, dr, 1e-6)), 1e-6);
    EXPECT_LT(rel_err(gq, fd_grad(fq, q.coeffs(), 1e-5)), 1e-6);
    // The cheap body torque equals the converted quaternion gradient.
    const Vec3 tq = coupling_torque(q.conjugate() * dr.normalized(), rest, kappa);
    EXPECT_LT(rel_err(tq, body_torque(q, gq)), 1e-10);
  }
}

TEST(EnergyGradient, BendTwistWithIntrinsicStrain) {
  for (int trial = 0; trial < 20; ++trial) {
    const Quat a = rand_quat();
    Quat b = near(a, 0.1);
    if (trial % 2) b.coeffs() *= -1.0;  // the gradient must hold in either hemisphere
    const double rest = uni(0.01, 0.1);
    const Vec3 k(uni(0.1, 1), uni(0.1, 1), uni(0.1, 1)), uhat = rand_vec(3.0);
    Vec4 ga, gb;
    bend_twist_energy(a, b, rest, k, uhat, &ga, &gb);
    Eigen::VectorXd x(8);
    x << a.coeffs(), b.coeffs();
    auto f = [&](const Eigen::VectorXd& y) {
      return bend_twist_energy(from4(y, 0), from4(y, 4), rest, k, uhat, nullptr, nullptr);
    };
    Eigen::VectorXd g(8);
    g << ga, gb;
    EXPECT_LT(rel_err(g, fd_grad(f, x, 1e-6)), 1e-6);
  }
}

// Virtual work: a body rotation dtheta moves q to q (x) exp(dtheta/2); tau . dtheta = -dE.
TEST(EnergyGradient, TorqueConversionVirtualWork) {
  for (int trial = 0; trial < 20; ++trial) {
    const Quat a = rand_quat(), b = near(a, 0.1);
    const double rest = 0.05;
    const Vec3 k(0.3, 0.4, 0.2), uhat = rand_vec(2.0);
    Vec4 ga, gb;
    bend_twist_energy(a, b, rest, k, uhat, &ga, &gb);
    const Vec3 tau = body_torque(b, gb);
    auto f = [&](const Eigen::VectorXd& th) {
      const Quat bb = b * Quat(Eigen::AngleAxisd(
                              th.norm(), th.norm() > 0 ? Vec3(th.normalized()) : Vec3::UnitX()));
      return bend_twist_energy(a, bb, rest, k, uhat, nullptr, nullptr);
    };
    const Eigen::VectorXd dEdtheta = fd_grad(f, Eigen::Vector3d::Zero(), 1e-6);
    EXPECT_LT(rel_err(tau, -dEdtheta), 1e-6);
  }
}

// The rod's assembled forces and torques equal minus the gradient of its total elastic energy.
TEST(EnergyGradient, RodForcesMatchTotalEnergy) {
  Section sec;
  sec.bend = 0.3;
  sec.twist = 0.2;
  sec.stretch = 50;
  sec.kappa = 20;
  sec.mass_per_length = 1;
  sec.inertia_bend = 1e-3;
  sec.inertia_twist = 2e-3;
  RodSpec spec;
  spec.shape.kind = RodShape::Kind::kHelix;
  spec.elements = 6;
  spec.section = sec;
  spec.rest_shape_created = true;
  Rod rod = build_rod(spec);
  for (auto& x : rod.positions()) x += rand_vec(0.01);
  for (auto& q : rod.orientations()) q = near(q, 0.05);
  rod.ghost_start() = GhostFrame{true, near(rod.orientations()[0], 0.1), rand_vec(1.0)};
  const Vec3 no_gravity = Vec3::Zero();
  rod.compute_forces(0.0, no_gravity);
  const auto f = rod.forces();
  const auto tau = rod.torques();
  for (int i = 0; i < rod.num_nodes(); ++i) {
    auto e = [&](const Eigen::VectorXd& p) {
      Rod r = rod;
      r.positions()[i] = p;
      return r.energies(no_gravity).elastic();
    };
    EXPECT_LT(rel_err(-f[i], fd_grad(e, rod.positions()[i], 1e-6)), 1e-6) << "node " << i;
  }
  for (int s = 0; s < rod.num_segments(); ++s) {
    auto e = [&](const Eigen::VectorXd& th) {
      Rod r = rod;
      const double ang = th.norm();
      if (ang > 0)
        r.orientations()[s] = r.orientations()[s] * Quat(Eigen::AngleAxisd(ang, th / ang));
      return r.energies(no_gravity).elastic();
    };
    EXPECT_LT(rel_err(-tau[s], fd_grad(e, Eigen::Vector3d::Zero(), 1e-6)), 1e-6) << "segment " << s;
  }
}

}  // namespace
}  // namespace corde
