// The shared rod system: analytic Hessian blocks of every term against central differences of the
// analytic gradient, the gradient against the rod's forces, rigid motions, and the O(N) solver.
#include "corde_sim/model/rod_system.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <iostream>
#include <random>

#include "corde_sim/linalg/block_tridiag_sparse.h"
#include "corde_sim/rod/rod_shape.h"

namespace corde {
namespace {

std::mt19937 rng(7);
double uni(double a, double b) { return std::uniform_real_distribution<double>(a, b)(rng); }
Vec3 rand_vec(double s) { return Vec3(uni(-s, s), uni(-s, s), uni(-s, s)); }
Quat turned(const Quat& q, double s) {
  const Vec3 th = rand_vec(s);
  return q * Quat(Eigen::AngleAxisd(th.norm(), th.normalized()));
}
Quat exp_body(const Vec3& th) {
  const double a = th.norm();
  return a > 0.0 ? Quat(Eigen::AngleAxisd(a, th / a)) : Quat::Identity();
}

Section test_section() {
  Section sec;
  sec.bend = 0.3;
  sec.twist = 0.2;
  sec.stretch = 50.0;
  sec.kappa = 20.0;
  sec.mass_per_length = 0.5;
  sec.inertia_bend = 1e-4;
  sec.inertia_twist = 2e-4;
  return sec;
}

// A pre-shaped helix (intrinsic curvature and twist) of 6 elements with ghost clamps at both
// ends, then moved off equilibrium: chords stretched and compressed, frames turned by up to
// ~0.3 rad (bent, twisted, sheared against the chords), one quaternion negated.
Rod random_rod() {
  RodSpec spec;
  spec.shape.kind = RodShape::Kind::kHelix;
  spec.shape.helix_radius = 0.05;
  spec.shape.helix_pitch = 0.1;
  spec.shape.helix_turns = 1.0;
  spec.elements = 6;
  spec.section = test_section();
  spec.rest_shape_created = true;
  Rod rod = build_rod(spec);
  for (auto& x : rod.positions()) x += rand_vec(0.01);
  for (auto& q : rod.orientations()) q = turned(q, 0.3);
  rod.orientations()[3].coeffs() *= -1.0;
  rod.ghost_start() = GhostFrame{true, turned(rod.orientations()[0], 0.3), rand_vec(2.0)};
  rod.ghost_end() = GhostFrame{true, turned(rod.orientations().back(), 0.3), rand_vec(2.0)};
  return rod;
}

// Moves unknown j of the system by h: a node component added, a rotation composed in the body.
void perturb(Rod* rod, int j, double h) {
  const int k = j / 6, c = j % 6;
  if (c < 3)
    rod->positions()[k](c) += h;
  else
    rod->orientations()[k] = rod->orientations()[k] * exp_body(h * Vec3::Unit(c - 3));
}

// Fourth-order central differences of the analytic gradient along the retraction, minus the skew
// term (1/2)[g_theta]x that the retraction adds to the torque Jacobian (model/rod_system.h): this
// is the Hessian of E(x + dx, q exp(theta/2)) at 0, which hessian() must give.
Eigen::MatrixXd fd_hessian(const Rod& rod, const RodSystem& sys_in) {
  const int n = sys_in.size();
  Eigen::MatrixXd fd = Eigen::MatrixXd::Zero(n, n);
  Eigen::VectorXd gp, gm, gp2, gm2, g0;
  RodSystem sys = sys_in;
  sys.rod = &rod;
  sys.gradient(&g0);
  const double l = rod.rest_lengths()[0];
  for (int j = 0; j < n; ++j) {
    if (j / 6 == rod.num_segments() && j % 6 >= 3) continue;  // the unused slot
    const double h = j % 6 < 3 ? 1e-5 * l : 1e-5;
    auto grad_at = [&](double s, Eigen::VectorXd* g) {
      Rod r = rod;
      perturb(&r, j, s);
      RodSystem rs = sys;
      rs.rod = &r;
      rs.gradient(g);
    };
    grad_at(h, &gp);
    grad_at(-h, &gm);
    grad_at(2 * h, &gp2);
    grad_at(-2 * h, &gm2);
    fd.col(j) = (8.0 * (gp - gm) - (gp2 - gm2)) / (12.0 * h);
  }
  for (int s = 0; s < rod.num_segments(); ++s) {
    const Vec3 g = g0.segment<3>(RodSystem::segment_index(s));
    Mat3 sk;
    sk << 0, -g.z(), g.y(), g.z(), 0, -g.x(), -g.y(), g.x(), 0;
    fd.block<3, 3>(RodSystem::segment_index(s), RodSystem::segment_index(s)) -= 0.5 * sk;
  }
  return fd;
}

// Largest error of a 3x3 block relative to max(|that block|, 1e-3 |largest block|).
double worst_block_error(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  double big = 0.0;
  for (int i = 0; i < a.rows(); i += 3)
    for (int j = 0; j < a.cols(); j += 3) big = std::max(big, a.block<3, 3>(i, j).norm());
  double worst = 0.0;
  for (int i = 0; i < a.rows(); i += 3)
    for (int j = 0; j < a.cols(); j += 3) {
      const double scale = std::max(a.block<3, 3>(i, j).norm(), 1e-3 * big);
      worst = std::max(worst, (a.block<3, 3>(i, j) - b.block<3, 3>(i, j)).norm() / scale);
    }
  return worst;
}

TEST(RodSystem, EveryHessianBlockMatchesDifferencesOfTheGradient) {
  const std::pair<unsigned, const char*> terms[] = {{kStretchTerm, "stretch"},
                                                    {kCouplingTerm, "coupling"},
                                                    {kBendTwistTerm, "bend-twist"},
                                                    {kGravityTerm | kLoadTerm, "loads"}};
  for (int trial = 0; trial < 3; ++trial) {
    Rod rod = random_rod();
    rod.add_load(Load{Load::Kind::kForce, 2, Vec3(0.3, -0.2, 0.1)});
    for (const auto& [term, name] : terms) {
      RodSystem sys{&rod, Vec3(0, 0, -9.81), 0.0, 1.0, term};
      BlockTridiag h;
      sys.hessian(&h);
      const Eigen::MatrixXd a = h.dense(), fd = fd_hessian(rod, sys);
      if (term & kStretchTerm || term & kCouplingTerm || term & kBendTwistTerm) {
        const double err = worst_block_error(a, fd);
        std::cout << name << ": worst block error " << err << "\n";
        EXPECT_LT(err, 1e-6) << name << " trial " << trial;
        // Symmetric by construction; the differences agree, so their skew part is the
        // retraction's (1/2)[g]x alone.
        EXPECT_LT((fd - fd.transpose()).norm(), 1e-6 * fd.norm()) << name;
      } else {
        EXPECT_EQ(a.norm(), 0.0);
        EXPECT_LT(fd.norm(), 1e-9) << name;  // gravity and dead forces are linear
      }
      EXPECT_LE((a - a.transpose()).norm(), 1e-14 * a.norm()) << name;
    }
  }
}

// The term functions on their own, over wider random states (both hemispheres, large strains).
TEST(RodSystem, TermHessiansMatchDifferencesOverWideStates) {
  for (int trial = 0; trial < 20; ++trial) {
    const Quat a = turned(Quat::UnitRandom(), 1.0);
    Quat b = turned(a, 0.8);
    if (trial % 2) b.coeffs() *= -1.0;
    const double l = uni(0.01, 0.1);
    const Vec3 k(uni(0.1, 1), uni(0.1, 1), uni(0.1, 1)), uhat = rand_vec(10.0);
    Mat3 haa, hab, hbb;
    bend_twist_hessian(a, b, l, k, uhat, &haa, &hab, &hbb);
    Eigen::Matrix<double, 6, 6> h, fd;
    h << haa, hab, hab.transpose(), hbb;
    // Column j: differences of the body gradients (from the torques of bend_twist_energy).
    auto grad = [&](const Quat& qa, const Quat& qb) {
      Vec4 ga, gb;
      bend_twist_energy(qa, qb, l, k, uhat, &ga, &gb);
      Eigen::Matrix<double, 6, 1> g;
      g << -body_torque(qa, ga), -body_torque(qb, gb);
      return g;
    };
    const double eps = 1e-5;
    for (int j = 0; j < 6; ++j) {
      auto at = [&](double s) {
        const Vec3 th = s * Vec3::Unit(j % 3);
        return j < 3 ? grad(a * exp_body(th), b) : grad(a, b * exp_body(th));
      };
      fd.col(j) = (8.0 * (at(eps) - at(-eps)) - (at(2 * eps) - at(-2 * eps))) / (12.0 * eps);
    }
    const Eigen::Matrix<double, 6, 1> g0 = grad(a, b);
    for (int s = 0; s < 2; ++s) {
      const Vec3 g = g0.segment<3>(3 * s);
      Mat3 sk;
      sk << 0, -g.z(), g.y(), g.z(), 0, -g.x(), -g.y(), g.x(), 0;
      fd.block<3, 3>(3 * s, 3 * s) -= 0.5 * sk;
    }
    EXPECT_LT((h - fd).norm(), 1e-6 * h.norm()) << "bend-twist trial " << trial;

    // Coupling and stretch of a chord far from d3 and far from its rest length.
    const Vec3 d = uni(0.5, 1.5) * l * (a * Vec3(uni(-1, 1), uni(-1, 1), 1.0)).normalized();
    const double kappa = uni(1, 100), ks = uni(10, 1000);
    Mat3 hdd, hdt, htt;
    coupling_hessian(d, a, l, kappa, &hdd, &hdt, &htt);
    auto cgrad = [&](const Vec3& dd, const Quat& q) {
      Vec3 gd;
      coupling_energy(dd, q, l, kappa, &gd, nullptr);
      Eigen::Matrix<double, 6, 1> g;
      g << gd, -coupling_torque(q.conjugate() * dd.normalized(), l, kappa);
      return g;
    };
    Eigen::Matrix<double, 6, 6> hc, fc;
    hc << hdd, hdt, hdt.transpose(), htt;
    for (int j = 0; j < 6; ++j) {
      auto at = [&](double s) {
        return j < 3 ? cgrad(d + s * l * Vec3::Unit(j), a)
                     : cgrad(d, a * exp_body(s * Vec3::Unit(j - 3)));
      };
      const double hj = j < 3 ? eps * l : eps;
      fc.col(j) = (8.0 * (at(eps) - at(-eps)) - (at(2 * eps) - at(-2 * eps))) / (12.0 * hj);
    }
    const Vec3 gt = cgrad(d, a).tail<3>();
    Mat3 sk;
    sk << 0, -gt.z(), gt.y(), gt.z(), 0, -gt.x(), -gt.y(), gt.x(), 0;
    fc.block<3, 3>(3, 3) -= 0.5 * sk;
    EXPECT_LT((hc - fc).norm(), 1e-6 * hc.norm()) << "coupling trial " << trial;

    auto sgrad = [&](const Vec3& dd) {
      Vec3 g;
      stretch_energy(dd, l, ks, &g);
      return g;
    };
    Mat3 fs;
    for (int j = 0; j < 3; ++j) {
      const Vec3 e = eps * l * Vec3::Unit(j);
      fs.col(j) = (8.0 * (sgrad(d + e) - sgrad(d - e)) - (sgrad(d + 2 * e) - sgrad(d - 2 * e))) /
                  (12.0 * eps * l);
    }
    const Mat3 hs = stretch_hessian(d, l, ks);
    EXPECT_LT((hs - fs).norm(), 1e-6 * hs.norm()) << "stretch trial " << trial;
  }
}

TEST(RodSystem, GradientIsMinusTheRodsForcesAndTorques) {
  Rod rod = random_rod();
  rod.add_load(Load{Load::Kind::kForce, 3, Vec3(0.5, 0.1, -0.2)});
  rod.add_load(Load{Load::Kind::kTorque, 2, Vec3(0.01, -0.02, 0.03)});
  rod.add_load(Load{Load::Kind::kForce, 5, Vec3(0.0, 0.4, 0.0), 0.0, 2.0});  // ramped: half
  const Vec3 g(0.0, 0.0, -9.81);
  const double t = 1.0;
  rod.compute_forces(t, g);
  RodSystem sys{&rod, g, t};
  Eigen::VectorXd grad;
  sys.gradient(&grad);
  double fmax = 0.0;
  for (const Vec3& f : rod.forces()) fmax = std::max(fmax, f.norm());
  for (int i = 0; i < rod.num_nodes(); ++i)
    EXPECT_LT((grad.segment<3>(6 * i) + rod.forces()[i]).norm(), 1e-12 * fmax) << "node " << i;
  const double l = rod.rest_lengths()[0];
  for (int s = 0; s < rod.num_segments(); ++s)
    EXPECT_LT((grad.segment<3>(6 * s + 3) + rod.torques()[s]).norm(), 1e-12 * fmax * l)
        << "segment " << s;
  EXPECT_EQ(grad.segment<3>(6 * rod.num_segments() + 3).norm(), 0.0);  // unused slot
}

// A rigid end body's centre of mass off its node (Rod::add_mass_offset): gravity's energy
// -m g.(x_node + R d) has the analytic gradient (against central differences of the energy along
// the retraction), the analytic Hessian (against differences of the gradient), the rod's torque
// as minus its body gradient, and the rod's energies' gravity; its definite variant is PSD.
TEST(RodSystem, MassOffsetGravityMatchesDifferences) {
  Rod rod = random_rod();
  const int n = rod.num_segments();
  rod.add_node_mass(n, 0.2);
  rod.add_mass_offset(n, 0.2, Vec3(0.01, -0.02, 0.05));
  rod.add_node_mass(0, 0.1);
  rod.add_mass_offset(0, 0.1, Vec3(0.0, 0.0, -0.03));
  const Vec3 g(0.3, -1.0, -9.81);
  RodSystem sys{&rod, g, 0.0, 1.0, kGravityTerm};
  Eigen::VectorXd grad;
  sys.gradient(&grad);
  // The gradient against fourth-order central differences of the energy.
  double worst = 0.0;
  for (int j = 0; j < sys.size(); ++j) {
    if (j / 6 == n && j % 6 >= 3) continue;
    const double h = 1e-4;
    auto energy_at = [&](double s) {
      Rod r = rod;
      perturb(&r, j, s);
      RodSystem rs = sys;
      rs.rod = &r;
      return rs.energy();
    };
    const double fd =
        (8.0 * (energy_at(h) - energy_at(-h)) - (energy_at(2 * h) - energy_at(-2 * h))) / (12 * h);
    worst = std::max(worst, std::abs(fd - grad(j)));
  }
  std::cout << "mass offset: worst gradient error " << worst << " of " << grad.norm() << "\n";
  EXPECT_LT(worst, 1e-9 * grad.norm());
  // The offsets' torque is there (the test sees it): on the end segments only.
  EXPECT_GT(grad.segment<3>(RodSystem::segment_index(n - 1)).norm(), 1e-3);
  EXPECT_GT(grad.segment<3>(RodSystem::segment_index(0)).norm(), 1e-3);
  EXPECT_EQ(grad.segment<3>(RodSystem::segment_index(2)).norm(), 0.0);
  // The Hessian against differences of the gradient.
  BlockTridiag h;
  sys.hessian(&h);
  const Eigen::MatrixXd a = h.dense(), fd = fd_hessian(rod, sys);
  std::cout << "mass offset: Hessian error " << (a - fd).norm() << " of " << a.norm() << "\n";
  EXPECT_GT(a.norm(), 1e-3);
  EXPECT_LT((a - fd).norm(), 1e-7 * a.norm());
  EXPECT_LE((a - a.transpose()).norm(), 1e-14 * a.norm());
  // The definite variant is positive semi-definite.
  sys.definite = true;
  sys.hessian(&h);
  EXPECT_GT(Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(h.dense()).eigenvalues().minCoeff(),
            -1e-12);
  // The rod's torques are minus the whole gradient, its energies' gravity the term's energy.
  rod.compute_forces(0.0, g);
  RodSystem all{&rod, g, 0.0};
  all.gradient(&grad);
  double fmax = 0.0;
  for (const Vec3& f : rod.forces()) fmax = std::max(fmax, f.norm());
  for (int s = 0; s < n; ++s)
    EXPECT_LT((grad.segment<3>(6 * s + 3) + rod.torques()[s]).norm(), 1e-12 * fmax)
        << "segment " << s;
  EXPECT_NEAR(rod.energies(g).gravity, sys.energy(), 1e-14 * std::abs(sys.energy()));
}

TEST(RodSystem, RigidMotionsAreInTheNullSpace) {
  // Translations at any state (each term sees only chord differences), exactly up to round-off.
  Rod rod = random_rod();
  rod.ghost_start().active = rod.ghost_end().active = false;  // ghost frames fix the rotation
  RodSystem sys{&rod};
  BlockTridiag h;
  sys.hessian(&h);
  const Eigen::MatrixXd a = h.dense();
  for (int c = 0; c < 3; ++c) {
    Eigen::VectorXd v = Eigen::VectorXd::Zero(sys.size());
    for (int i = 0; i < rod.num_nodes(); ++i) v(6 * i + c) = 1.0;
    EXPECT_LT((a * v).norm(), 1e-13 * a.norm() * v.norm()) << "translation " << c;
  }
  // Rotations at the rest state (a pre-shaped helix as created: zero gradient): a world rotation
  // omega moves node x by omega x x and turns segment s by R_s^T omega in its body.
  RodSpec spec;
  spec.shape.kind = RodShape::Kind::kHelix;
  spec.elements = 8;
  spec.section = test_section();
  spec.rest_shape_created = true;
  Rod rest = build_rod(spec);
  RodSystem rs{&rest};
  rs.hessian(&h);
  const Eigen::MatrixXd b = h.dense();
  for (int c = 0; c < 3; ++c) {
    const Vec3 w = Vec3::Unit(c);
    Eigen::VectorXd v = Eigen::VectorXd::Zero(rs.size());
    for (int i = 0; i < rest.num_nodes(); ++i) v.segment<3>(6 * i) = w.cross(rest.positions()[i]);
    for (int s = 0; s < rest.num_segments(); ++s)
      v.segment<3>(6 * s + 3) = rest.orientations()[s].conjugate() * w;
    EXPECT_LT((b * v).norm(), 1e-10 * b.norm() * v.norm()) << "rotation " << c;
  }
}

// The definite variant: positive semi-definite at off-equilibrium states where the exact Hessian
// is not, and the exact Hessian at the rest state.
TEST(RodSystem, DefiniteVariantIsPositiveSemiDefiniteAndExactAtRest) {
  for (int trial = 0; trial < 3; ++trial) {
    Rod rod = random_rod();
    // Compressed by 5 % with a soft penalty: the stretch's negative geometric stiffness wins.
    for (auto& x : rod.positions()) x *= 0.95;
    Section soft = rod.section();
    soft.kappa = 0.5;
    rod.set_section(soft);
    RodSystem sys{&rod};
    BlockTridiag h;
    sys.hessian(&h);
    const Eigen::MatrixXd exact = h.dense();
    sys.definite = true;
    sys.hessian(&h);
    const Eigen::MatrixXd psd = h.dense();
    const double lo_exact = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(exact).eigenvalues()(0);
    const double lo_psd = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(psd).eigenvalues()(0);
    EXPECT_LT(lo_exact, -1e-3 * exact.norm()) << "the test state should be indefinite";
    EXPECT_GT(lo_psd, -1e-12 * psd.norm());
  }
  RodSpec spec;
  spec.shape.kind = RodShape::Kind::kHelix;
  spec.elements = 8;
  spec.section = test_section();
  spec.rest_shape_created = true;
  Rod rest = build_rod(spec);
  RodSystem sys{&rest};
  BlockTridiag h;
  sys.hessian(&h);
  const Eigen::MatrixXd exact = h.dense();
  sys.definite = true;
  sys.hessian(&h);
  EXPECT_LT((h.dense() - exact).norm(), 1e-12 * exact.norm());
}

// Both ghost clamps take the definite variant. A clamp's frame bent by 2 rad against its ghost
// frame (past a quarter turn) makes the exact term indefinite: about x its curvature is
// (k/l) cos(2 rad) < 0. The definite term is the Gauss-Newton J^T (l k) J alone, with
// J = (sigma/l)([v]x -+ w I) the Jacobian of u on the rod's own segment (- at the end clamp,
// where the segment is the element's first frame; + at the start clamp, where it is the second).
TEST(RodSystem, DefiniteVariantAtBothGhostClamps) {
  for (const bool at_end : {false, true}) {
    Rod rod = random_rod();
    const int n = rod.num_segments(), s = at_end ? n - 1 : 0;
    const Quat bent = rod.orientations()[s] * exp_body(Vec3(2.0, 0.0, 0.0));
    rod.ghost_start().active = !at_end;
    rod.ghost_end().active = at_end;
    (at_end ? rod.ghost_end() : rod.ghost_start()) = GhostFrame{true, bent, Vec3::Zero()};
    RodSystem sys{&rod, Vec3::Zero(), 0.0, 1.0, kBendTwistTerm};
    sys.definite = true;
    BlockTridiag with, without;
    sys.hessian(&with);
    // The clamp's own contribution: the difference to the same rod without it.
    Rod free_rod = rod;
    free_rod.ghost_start().active = free_rod.ghost_end().active = false;
    RodSystem free_sys = sys;
    free_sys.rod = &free_rod;
    free_sys.hessian(&without);
    const Eigen::MatrixXd clamp = with.dense() - without.dense();
    const int ts = RodSystem::segment_index(s);
    // Hand-computed: element (a, b) = (q_s, ghost) at the end, (ghost, q_s) at the start.
    const Quat a = at_end ? rod.orientations()[s] : bent, b = at_end ? bent : rod.orientations()[s];
    const double w = a.coeffs().dot(b.coeffs()), sigma = w < 0.0 ? -1.0 : 1.0;
    const Vec3 v = (a.conjugate() * b).vec();
    const double l = 0.5 * rod.rest_lengths()[s];
    Mat3 sv;
    sv << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
    const Mat3 j = (sigma / l) * (sv + (at_end ? -w : w) * Mat3::Identity());
    const Vec3 k(rod.section().bend, rod.section().bend, rod.section().twist);
    const Mat3 expected = j.transpose() * (l * k).asDiagonal() * j;
    EXPECT_LT((clamp.block<3, 3>(ts, ts) - expected).norm(), 1e-12 * expected.norm())
        << (at_end ? "end" : "start") << " clamp";
    Eigen::MatrixXd rest_of_it = clamp;
    rest_of_it.block<3, 3>(ts, ts).setZero();
    EXPECT_EQ(rest_of_it.norm(), 0.0);
    // Positive semi-definite, where the exact clamp term is not.
    const double lo =
        Eigen::SelfAdjointEigenSolver<Mat3>(clamp.block<3, 3>(ts, ts)).eigenvalues()(0);
    EXPECT_GT(lo, -1e-12 * expected.norm()) << (at_end ? "end" : "start") << " clamp";
    sys.definite = free_sys.definite = false;
    sys.hessian(&with);
    free_sys.hessian(&without);
    const Mat3 exact = (with.dense() - without.dense()).block<3, 3>(ts, ts);
    EXPECT_LT(Eigen::SelfAdjointEigenSolver<Mat3>(exact).eigenvalues()(0), -0.1 * exact.norm())
        << "the test state should make the exact clamp term indefinite";
  }
}

// M/h^2 + H of a cable with its first node and segment fixed, as an implicit step solves it.
BlockTridiag step_matrix(int elements, Rod* out = nullptr) {
  RodSpec spec;
  spec.shape.length = 1.0;
  spec.elements = elements;
  spec.section = test_section();
  Rod rod = build_rod(spec);
  for (auto& x : rod.positions()) x += rand_vec(0.002);
  for (auto& q : rod.orientations()) q = turned(q, 0.05);
  RodSystem sys{&rod, Vec3(0, 0, -9.81)};
  BlockTridiag a;
  sys.hessian(&a);
  const double h = 2e-3;
  for (int i = 0; i < rod.num_nodes(); ++i)
    a.diag[i].topLeftCorner<3, 3>().diagonal().array() += rod.node_masses()[i] / (h * h);
  for (int s = 0; s < rod.num_segments(); ++s)
    a.diag[s].bottomRightCorner<3, 3>().diagonal() += rod.segment_inertia(s) / (h * h);
  for (int c = 0; c < 6; ++c) a.fix(c);                           // clamp: node 0, segment 0
  for (int c = 3; c < 6; ++c) a.fix(6 * rod.num_segments() + c);  // the unused slot
  if (out) *out = rod;
  return a;
}

TEST(BlockTridiagSolver, MatchesADenseSolve) {
  for (int n : {1, 2, 7, 40}) {
    const BlockTridiag a = step_matrix(n);
    Eigen::VectorXd b = Eigen::VectorXd::Random(a.size());
    for (int c = 0; c < 6; ++c) b(c) = 0.0;
    const Eigen::VectorXd ref = a.dense().ldlt().solve(b);
    BlockTridiagSolver solver;
    ASSERT_TRUE(solver.factor(a)) << n;
    Eigen::VectorXd x = b;
    solver.solve(&x);
    EXPECT_LT((x - ref).norm(), 1e-10 * ref.norm()) << n;
    Eigen::VectorXd ax;
    a.multiply(x, &ax);
    EXPECT_LT((ax - b).norm(), 1e-10 * b.norm()) << n;
    EXPECT_LT((to_sparse(a) * x - b).norm(), 1e-10 * b.norm()) << n;
  }
}

// Takahashi's recurrences give the diagonal and first subdiagonal blocks of the dense inverse.
TEST(BlockTridiagSolver, SelectedInverseMatchesTheDenseInverse) {
  for (int n : {1, 2, 7, 40}) {
    const BlockTridiag a = step_matrix(n);
    BlockTridiagSolver solver;
    ASSERT_TRUE(solver.factor(a)) << n;
    std::vector<Mat6> diag, lower;
    solver.selected_inverse(&diag, &lower);
    const Eigen::MatrixXd inv = a.dense().inverse();
    ASSERT_EQ(static_cast<int>(diag.size()), a.blocks());
    ASSERT_EQ(static_cast<int>(lower.size()), a.blocks() - 1);
    const double scale = inv.cwiseAbs().maxCoeff();
    for (int k = 0; k < a.blocks(); ++k) {
      EXPECT_LT((diag[k] - inv.block<6, 6>(6 * k, 6 * k)).cwiseAbs().maxCoeff(), 1e-10 * scale)
          << n << " block " << k;
      if (k + 1 < a.blocks()) {
        EXPECT_LT((lower[k] - inv.block<6, 6>(6 * k + 6, 6 * k)).cwiseAbs().maxCoeff(),
                  1e-10 * scale)
            << n << " block " << k;
      }
    }
  }
}

TEST(BlockTridiagSolver, RefusesAnIndefiniteMatrix) {
  BlockTridiag a = step_matrix(10);
  BlockTridiagSolver solver;
  EXPECT_TRUE(solver.factor(a));
  a.diag[6](1, 1) = -1e6;  // a negative stiffness in the middle of the rod
  EXPECT_FALSE(solver.factor(a));
}

}  // namespace
}  // namespace corde
