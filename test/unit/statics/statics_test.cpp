// The static solver: zero residual at its result, agreement with dynamic relaxation, exact pure
// bending under a torque load, continuation, and the planar option.
#include "corde_sim/statics/statics.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <chrono>
#include <cmath>
#include <iostream>

#include "corde_sim/stability/explicit_step_limit.h"
#include "corde_sim/statics/static_hessian.h"
#include "validation_util.h"

namespace corde {
namespace {

using val::Clamp;

Rod tip_loaded(int n, double alpha, Clamp clamp, double stiff) {
  Rod rod = val::straight_rod(val::example_material(stiff), n);
  val::clamp_start(&rod, clamp);
  Load l;
  l.index = n;
  l.value = Vec3(0.0, 0.0, -alpha * rod.section().bend / (val::kLength * val::kLength));
  rod.add_load(l);
  return rod;
}

// Largest force on a free node and torque / (L/N) on a free segment, recomputed by the rod
// itself (loads included) at the solver's result.
double max_free_residual(Rod& rod, const Vec3& gravity) {
  rod.compute_forces(0.0, gravity);
  const double lc = val::kLength / rod.num_segments();
  double worst = 0.0;
  for (int i = 0; i < rod.num_nodes(); ++i)
    if (!rod.node_drive(i)) worst = std::max(worst, rod.forces()[i].norm());
  for (int s = 0; s < rod.num_segments(); ++s)
    if (!rod.segment_drive(s)) worst = std::max(worst, rod.torques()[s].norm() / lc);
  return worst;
}

// N = 20, alpha = 3 tip load plus self-weight, both clamps, example rod (E_s, kappa as given):
// every free node and segment is in equilibrium to 1e-9 of the tip load.
TEST(Statics, ResultHasZeroResidual) {
  for (Clamp clamp : {Clamp::kNatural, Clamp::kGhost}) {
    Rod rod = tip_loaded(20, 3.0, clamp, 1.0);
    const Vec3 g(0.0, 0.0, -0.5);
    const StaticResult res = solve_statics(rod, g, 0.0);
    const double p = 3.0 * rod.section().bend;
    const double worst = max_free_residual(rod, g);
    std::cout << val::clamp_name(clamp) << ": iterations " << res.iterations << ", residual "
              << res.residual << " N (relative " << res.relative_residual << ", floor "
              << res.round_off_floor << "), max free force " << worst << " N\n";
    EXPECT_TRUE(res.converged);
    EXPECT_LE(res.iterations, 15);
    EXPECT_LT(worst, 1e-9 * p);
    EXPECT_GT(-rod.positions()[20].z(), 0.5);  // it did deflect
  }
}

// Damped dynamic relaxation (kinetic damping: velocities zeroed at every peak of the kinetic
// energy) of the same small cantilever, N = 10, alpha = 1, ghost clamp, example rod, reaches the
// static solution to 1e-6 L.
TEST(Statics, AgreesWithDynamicRelaxation) {
  Rod stat = tip_loaded(10, 1.0, Clamp::kGhost, 1.0);
  Rod dyn = stat;
  const StaticResult res = solve_statics(stat, Vec3::Zero(), 0.0);
  ASSERT_TRUE(res.converged);
  const double h = 0.8 * critical_time_step(dyn);
  double prev = 0.0;
  long steps = 0;
  Vec3 last_tip = dyn.positions()[10];
  for (; steps < 400000; ++steps) {
    dyn.step(steps * h, h, Vec3::Zero());
    const double ke = dyn.energies(Vec3::Zero()).kinetic();
    if (ke < prev) {
      for (auto& v : dyn.velocities()) v.setZero();
      for (auto& w : dyn.angular_velocities()) w.setZero();
      prev = 0.0;
    } else {
      prev = ke;
    }
    if (steps % 2000 == 0) {
      if ((dyn.positions()[10] - last_tip).norm() < 1e-11) break;
      last_tip = dyn.positions()[10];
    }
  }
  double worst = 0.0;
  for (int i = 0; i <= 10; ++i)
    worst = std::max(worst, (dyn.positions()[i] - stat.positions()[i]).norm());
  std::cout << "dynamic relaxation: " << steps << " steps of " << h << " s, tip deflection "
            << -dyn.positions()[10].z() << " vs static " << -stat.positions()[10].z()
            << ", max node distance " << worst << " m; static: " << res.iterations
            << " Newton iterations\n";
  EXPECT_LT(worst, 1e-6 * val::kLength);
}

// A dead end moment M on the last segment bends a cantilever into an arc: every bending element
// carries M. An element of rest length l has energy (l/2) B u^2 with u = (2/l) sin(phi/2) for a
// relative rotation phi, so its moment is (B/l) sin(phi) and phi = asin(M l / B) exactly (the
// continuum's M l / B up to O(l^2)). The tip segment turns by (N-1) asin(M l/B), plus
// asin(M l/(2B)) for the ghost element. M L / B = 2 (a large rotation), N = 20; the dead world
// torque is conservative for rotation about its own axis. Tolerance 1e-8 rad.
TEST(Statics, EndMomentGivesExactArc) {
  const int n = 20;
  const double l = val::kLength / n;
  for (Clamp clamp : {Clamp::kNatural, Clamp::kGhost}) {
    Rod rod = val::straight_rod(val::example_material(), n);
    val::clamp_start(&rod, clamp);
    const double b = rod.section().bend, m = 2.0 * b / val::kLength;
    Load load;
    load.kind = Load::Kind::kTorque;
    load.index = n - 1;
    load.value = Vec3(0.0, m, 0.0);  // turns the tip down (about +y: x towards -z)
    rod.add_load(load);
    StaticOptions opt;
    opt.load_steps = 2;
    const StaticResult res = solve_statics(rod, Vec3::Zero(), 0.0, opt);
    EXPECT_TRUE(res.converged);
    double expected = (n - 1) * std::asin(m * l / b);
    if (clamp == Clamp::kGhost) expected += std::asin(0.5 * m * l / b);
    const double angle = val::droop_angle(rod, n - 1);
    std::cout << val::clamp_name(clamp) << ": tip segment angle " << angle << " rad, expected "
              << expected << ", iterations " << res.iterations << "\n";
    EXPECT_NEAR(angle, expected, 1e-8);
  }
}

// Continuation (10 load steps), the planar option (normal y) and one step reach the same state
// for alpha = 10, ghost clamp, N = 40, stiff stretch and penalty (1e-9 L).
TEST(Statics, ContinuationAndPlanarAgree) {
  Rod one = tip_loaded(40, 10.0, Clamp::kGhost, 1e3);
  Rod ramp = one, planar = one;
  const auto t0 = std::chrono::steady_clock::now();
  const StaticResult r1 = solve_statics(one, Vec3::Zero(), 0.0);
  const double ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  StaticOptions opt;
  opt.load_steps = 10;
  const StaticResult r2 = solve_statics(ramp, Vec3::Zero(), 0.0, opt);
  opt.load_steps = 1;
  opt.plane_normal = Vec3::UnitY();
  const StaticResult r3 = solve_statics(planar, Vec3::Zero(), 0.0, opt);
  std::cout << "one step: " << r1.iterations << " iterations, " << r1.gradient_evaluations
            << " force evaluations, " << ms << " ms; 10 load steps: " << r2.iterations
            << " iterations; planar: " << r3.iterations << " iterations, " << r3.unknowns
            << " unknowns (3D " << r1.unknowns << ")\n";
  EXPECT_TRUE(r1.converged && r2.converged && r3.converged);
  EXPECT_EQ(r2.load_steps, 10);
  EXPECT_EQ(r3.unknowns, 3 * 40);
  for (int i = 0; i <= 40; ++i) {
    EXPECT_LT((one.positions()[i] - ramp.positions()[i]).norm(), 1e-9);
    EXPECT_LT((one.positions()[i] - planar.positions()[i]).norm(), 1e-9);
  }
}

// Drives are evaluated at t: a velocity-driven end of a pinned-pinned rod (node 0 fixed) is
// stretched to origin + v t, and the tension is K_s times the strain (N = 10, 1e-9 relative).
TEST(Statics, DrivesAtTimeT) {
  Rod rod = val::straight_rod(val::example_material(), 10);
  NodeDrive fixed;
  fixed.node = 0;
  rod.add_node_drive(fixed);
  NodeDrive pull;
  pull.kind = NodeDrive::Kind::kVelocity;
  pull.node = 10;
  pull.origin = rod.positions()[10];
  pull.velocity = Vec3(1e-3, 0.0, 0.0);
  pull.t_start = 1.0;
  rod.add_node_drive(pull);
  const StaticResult res = solve_statics(rod, Vec3::Zero(), 3.0);
  EXPECT_TRUE(res.converged);
  EXPECT_NEAR(rod.positions()[10].x(), 1.002, 1e-15);
  EXPECT_NEAR(rod.positions()[5].x(), 0.501, 1e-12);
  rod.compute_forces(3.0, Vec3::Zero());
  const double tension = -rod.forces()[10].x();
  EXPECT_NEAR(tension / (rod.section().stretch * 2e-3), 1.0, 1e-9);
}

// The Hessian is symmetric, and positive definite for a clamped cantilever (N = 10, 3D).
TEST(Statics, HessianOfClampedRodIsPositiveDefinite) {
  Rod rod = tip_loaded(10, 1.0, Clamp::kGhost, 1.0);
  solve_statics(rod, Vec3::Zero(), 0.0);
  const Eigen::MatrixXd h(static_hessian(rod, Vec3::Zero(), 0.0));
  EXPECT_EQ(h.rows(), 6 * 10);
  EXPECT_LT((h - h.transpose()).norm(), 1e-12 * h.norm());
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(h);
  EXPECT_GT(es.eigenvalues()(0), 0.0);
}

// The analytic Hessian (model/rod_system.h, in statics' scaled and planar unknowns) against the
// former fourth-order differences of the forces, off equilibrium (N = 12, 3D and planar, gravity
// and a tip load, stretched and turned), and both Newton variants reach the same equilibrium.
TEST(Statics, AnalyticHessianMatchesDifferencesAndSolvesTheSame) {
  Rod rod = tip_loaded(12, 3.0, Clamp::kGhost, 1.0);
  const Vec3 g(0.0, 0.0, -0.5);
  for (int i = 1; i <= 12; ++i) rod.positions()[i] += Vec3(0.01 * i, 0.0, -0.02 * i * i / 12.0);
  for (int s = 1; s < 12; ++s)
    rod.orientations()[s] = rod.orientations()[s] * Quat(Eigen::AngleAxisd(0.1 * s, Vec3::UnitY()));
  for (const Vec3& normal : {Vec3(0.0, 0.0, 0.0), Vec3(0.0, 1.0, 0.0)}) {
    StaticOptions exact, fd;
    exact.plane_normal = fd.plane_normal = normal;
    fd.finite_difference_hessian = true;
    Rod a = rod, b = rod;
    const Eigen::MatrixXd ha(static_hessian(a, g, 0.0, exact));
    const Eigen::MatrixXd hb(static_hessian(b, g, 0.0, fd));
    EXPECT_LT((ha - hb).norm(), 1e-6 * ha.norm()) << "normal " << normal.transpose();
    const StaticResult ra = solve_statics(a, g, 0.0, exact);
    const StaticResult rb = solve_statics(b, g, 0.0, fd);
    std::cout << (normal.norm() > 0 ? "planar" : "3D") << ": analytic " << ra.iterations
              << " iterations, " << ra.gradient_evaluations << " force evaluations; differences "
              << rb.iterations << " iterations, " << rb.gradient_evaluations
              << " force evaluations; |H - H_fd| / |H| " << (ha - hb).norm() / ha.norm() << "\n";
    EXPECT_TRUE(ra.converged && rb.converged);
    for (int i = 0; i <= 12; ++i) EXPECT_LT((a.positions()[i] - b.positions()[i]).norm(), 1e-9);
  }
}

}  // namespace
}  // namespace corde
