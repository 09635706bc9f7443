// Golden comparison of Rod::compute_forces and Rod::step against a straightforward reference
// written here from the element energies of model/element_energies.h (forces from their gradients,
// body torques through body_torque) and the integrator of docs/model.md, so that optimisations of
// the rod kernel (fused loops, precomputed inverses, relative rotations) cannot change the physics.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>
#include <vector>

#include "corde_sim/model/element_energies.h"
#include "corde_sim/rod/material.h"
#include "corde_sim/rod/rod.h"
#include "corde_sim/rod/rod_shape.h"
#include "corde_sim/stability/explicit_step_limit.h"

namespace corde {
namespace {

struct RefForces {
  std::vector<Vec3> f, tau;
  // Largest single contribution: the scale of the rounding error of a sum of contributions.
  double f_scale = 0.0, tau_scale = 0.0;
};

// Every term written the plain way: energies through their gradients, dissipation through the
// gradient of its Rayleigh function in world quantities, body torques as R^T times world torques.
RefForces reference_forces(const Rod& rod, double t, const Vec3& gravity) {
  const int n = rod.num_segments();
  const Section& sec = rod.section();
  const auto& x = rod.positions();
  const auto& v = rod.velocities();
  const auto& q = rod.orientations();
  const auto& w = rod.angular_velocities();
  const auto& rest = rod.rest_lengths();
  RefForces r;
  r.f.assign(n + 1, Vec3::Zero());
  r.tau.assign(n, Vec3::Zero());
  auto add_f = [&](int i, const Vec3& f) {
    r.f[i] += f;
    r.f_scale = std::max(r.f_scale, f.norm());
  };
  auto add_tau = [&](int s, const Vec3& tau) {
    r.tau[s] += tau;
    r.tau_scale = std::max(r.tau_scale, tau.norm());
  };
  auto rot_t = [&](int s) { return Eigen::Matrix3d(q[s].toRotationMatrix().transpose()); };

  for (int i = 0; i <= n; ++i) add_f(i, rod.node_masses()[i] * gravity);
  for (const Load& l : rod.loads()) {
    const Vec3 value = l.scale(t) * l.value;
    if (l.kind == Load::Kind::kForce)
      add_f(l.index, value);
    else
      add_tau(l.index, rot_t(l.index) * value);
  }
  for (int s = 0; s < n; ++s) {
    const Vec3 dr = x[s + 1] - x[s];
    Vec3 g;
    stretch_energy(dr, rest[s], sec.stretch, &g);
    add_f(s, g);
    add_f(s + 1, -g);
    Vec4 gq;
    coupling_energy(dr, q[s], rest[s], sec.kappa, &g, &gq);
    add_f(s, g);
    add_f(s + 1, -g);
    add_tau(s, body_torque(q[s], gq));
    // Rayleigh function D = gamma_t / (2 l) (t . dv)^2, force -dD/dv.
    const Vec3 tan = dr.normalized();
    const Vec3 fd = (sec.gamma_t / rest[s]) * tan.dot(v[s + 1] - v[s]) * tan;
    add_f(s, fd);
    add_f(s + 1, -fd);
  }
  const Vec3 k(sec.bend, sec.bend, sec.twist);
  for (int j = 0; j + 1 < n; ++j) {
    const double l = 0.5 * (rest[j] + rest[j + 1]);
    Vec4 ga, gb;
    bend_twist_energy(q[j], q[j + 1], l, k, rod.rest_strains()[j], &ga, &gb);
    add_tau(j, body_torque(q[j], ga));
    add_tau(j + 1, body_torque(q[j + 1], gb));
    // D = gamma_r / (2 l) |w_world(j+1) - w_world(j)|^2.
    const Vec3 dw = q[j + 1].toRotationMatrix() * w[j + 1] - q[j].toRotationMatrix() * w[j];
    add_tau(j, rot_t(j) * ((sec.gamma_r / l) * dw));
    add_tau(j + 1, -(rot_t(j + 1) * ((sec.gamma_r / l) * dw)));
  }
  Vec4 g;
  if (rod.ghost_start().active) {
    bend_twist_energy(rod.ghost_start().frame, q[0], 0.5 * rest[0], k, rod.ghost_start().uhat,
                      nullptr, &g);
    add_tau(0, body_torque(q[0], g));
  }
  if (rod.ghost_end().active) {
    bend_twist_energy(q[n - 1], rod.ghost_end().frame, 0.5 * rest[n - 1], k, rod.ghost_end().uhat,
                      &g, nullptr);
    add_tau(n - 1, body_torque(q[n - 1], g));
  }
  return r;
}

// Semi-implicit Euler of the nodes, the segments' rotations by either integrator of
// docs/model.md (the paper's eqs. 37-42, or the split rotation), then the drives at the end of
// the step.
void reference_step(Rod* rod, double t, double h, const Vec3& gravity, Integrator integrator) {
  const RefForces r = reference_forces(*rod, t, gravity);
  const int n = rod->num_segments();
  std::vector<bool> node_kin(n + 1, false), seg_kin(n, false);
  for (const NodeDrive& d : rod->node_drives()) node_kin[d.node] = true;
  for (const SegmentDrive& d : rod->segment_drives()) seg_kin[d.segment] = true;
  for (int i = 0; i <= n; ++i) {
    if (node_kin[i]) continue;
    rod->velocities()[i] += h / rod->node_masses()[i] * r.f[i];
    rod->positions()[i] += h * rod->velocities()[i];
  }
  for (int s = 0; s < n; ++s) {
    if (seg_kin[s]) continue;
    const Eigen::Matrix3d inertia = rod->segment_inertia(s).asDiagonal();
    Vec3& w = rod->angular_velocities()[s];
    Quat& q = rod->orientations()[s];
    if (integrator == Integrator::kSemiImplicitEuler) {
      w += h * inertia.inverse() * (r.tau[s] - w.cross(inertia * w));
      const Quat dq = q * Quat(0.0, w.x(), w.y(), w.z());
      q.coeffs() += 0.5 * h * dq.coeffs();
      q.normalize();
    } else {
      // Kick, then the free axisymmetric rotation: the frame turns by the Cayley angle
      // 2 atan(h |a|/2) about a = I w / I1 and back by 2 atan(h Omega/2) about d3, and (w1, w2)
      // turns forward by that same angle (here with cos and sin of it).
      w += h * inertia.inverse() * r.tau[s];
      const double i1 = inertia(0, 0), i3 = inertia(2, 2);
      const double omega = (i3 - i1) / i1 * w.z();
      const Vec3 a(w.x(), w.y(), i3 / i1 * w.z());
      const double angle_a = 2.0 * std::atan(0.5 * h * a.norm());
      const double angle_3 = 2.0 * std::atan(0.5 * h * omega);
      const Quat turn_a =
          a.norm() > 0.0 ? Quat(Eigen::AngleAxisd(angle_a, a.normalized())) : Quat::Identity();
      q = (q * turn_a * Quat(Eigen::AngleAxisd(-angle_3, Vec3::UnitZ()))).normalized();
      w = Eigen::AngleAxisd(angle_3, Vec3::UnitZ()) * w;
    }
  }
  const double t_end = t + h;
  for (const NodeDrive& d : rod->node_drives()) {
    Vec3& x = rod->positions()[d.node];
    Vec3& v = rod->velocities()[d.node];
    const bool started = t_end > d.t_start;
    if (d.kind == NodeDrive::Kind::kFixed) {
      x = d.origin;
      v.setZero();
    } else if (d.kind == NodeDrive::Kind::kVelocity) {
      x = d.origin + (started ? t_end - d.t_start : 0.0) * d.velocity;
      v = started ? d.velocity : Vec3::Zero();
    } else {
      v = (d.target - x) / h;
      x = d.target;
    }
  }
  for (const SegmentDrive& d : rod->segment_drives()) {
    Quat& q = rod->orientations()[d.segment];
    Vec3& w = rod->angular_velocities()[d.segment];
    const bool started = t_end > d.t_start;
    if (d.kind == SegmentDrive::Kind::kFixed) {
      q = d.origin;
      w.setZero();
    } else if (d.kind == SegmentDrive::Kind::kSpin) {
      const double angle = started ? d.rate * (t_end - d.t_start) : 0.0;
      q = d.origin * Quat(Eigen::AngleAxisd(angle, Vec3::UnitZ()));
      w = started ? Vec3(0.0, 0.0, d.rate) : Vec3::Zero();
    } else {
      Quat target = d.target.normalized();
      if (target.coeffs().dot(q.coeffs()) < 0.0) target.coeffs() *= -1.0;
      const Eigen::AngleAxisd delta(q.conjugate() * target);
      w = (delta.angle() / h) * delta.axis();
      q = target;
    }
  }
}

class StepRegression : public ::testing::Test {
 protected:
  std::mt19937 rng{20070803};
  double uni(double a, double b) { return std::uniform_real_distribution<double>(a, b)(rng); }
  Vec3 rand_vec(double s) { return Vec3(uni(-s, s), uni(-s, s), uni(-s, s)); }
  Quat rand_quat() {
    return Quat(Vec4(uni(-1, 1), uni(-1, 1), uni(-1, 1), uni(-1, 1))).normalized();
  }

  // The example material of docs/validation_references.md with internal friction and a distinct
  // twist stiffness.
  Section section() {
    Material m;
    m.youngs_modulus = 1e7;
    m.stretch_modulus = 2e7;
    m.shear_modulus = 1e7 / 2.6;
    m.density = 1000.0;
    m.kappa = m.shear_modulus * M_PI * 1e-4;
    m.gamma_t = 0.05;
    m.gamma_r = 2e-7;
    return make_section(m, 0.01);
  }

  // A wavy rod with unequal rest lengths, random intrinsic strains and small random state.
  Rod wavy_rod(int n, double state_scale) {
    RodSpec spec;
    spec.elements = n;
    spec.shape.length = 0.5;
    spec.section = section();
    Rod rod = build_rod(spec);
    std::vector<double> rest = rod.rest_lengths();
    for (double& l : rest) l *= uni(0.8, 1.2);
    rod.set_rest_lengths(rest);
    for (Vec3& x : rod.positions()) x += rand_vec(0.1 * state_scale * 0.5 / n);
    for (Quat& q : rod.orientations())
      q = (q * Quat(Eigen::AngleAxisd(0.1 * state_scale, rand_vec(1).normalized()))).normalized();
    for (Vec3& u : rod.rest_strains()) u = rand_vec(2.0);
    for (Vec3& v : rod.velocities()) v = rand_vec(0.1 * state_scale);
    for (Vec3& w : rod.angular_velocities()) w = rand_vec(1.0 * state_scale);
    return rod;
  }

  void expect_forces_match(Rod& rod, double t, const Vec3& gravity) {
    rod.compute_forces(t, gravity);
    const RefForces r = reference_forces(rod, t, gravity);
    double ef = 0.0, et = 0.0;
    for (int i = 0; i < rod.num_nodes(); ++i) ef = std::max(ef, (rod.forces()[i] - r.f[i]).norm());
    for (int s = 0; s < rod.num_segments(); ++s)
      et = std::max(et, (rod.torques()[s] - r.tau[s]).norm());
    EXPECT_LE(ef, 1e-12 * r.f_scale) << "force scale " << r.f_scale;
    EXPECT_LE(et, 1e-12 * r.tau_scale) << "torque scale " << r.tau_scale;
    max_rel_f = std::max(max_rel_f, ef / r.f_scale);
    max_rel_tau = std::max(max_rel_tau, et / r.tau_scale);
  }
  double max_rel_f = 0.0, max_rel_tau = 0.0;
};

// Arbitrary (far from physical) states: random unit quaternions in random hemispheres, so that
// the sign handling of the bending element is exercised, strains, loads mid-ramp, ghost frames.
TEST_F(StepRegression, ForcesOnRandomStatesMatchTheReference) {
  for (int trial = 0; trial < 20; ++trial) {
    const int n = 1 + trial % 7 + (trial > 10 ? 40 : 0);
    Rod rod = wavy_rod(n, 1.0);
    for (Quat& q : rod.orientations()) q = rand_quat();
    for (Vec3& x : rod.positions()) x += rand_vec(0.3 / n);
    rod.ghost_start().active = trial % 2 == 0;
    rod.ghost_start().frame = rand_quat();
    rod.ghost_start().uhat = rand_vec(3.0);
    rod.ghost_end().active = trial % 3 != 2;
    rod.ghost_end().frame = rand_quat();
    rod.ghost_end().uhat = rand_vec(3.0);
    const double t = 0.3;
    rod.add_load({Load::Kind::kForce, trial % (n + 1), rand_vec(2.0), 0.1, 0.5});
    rod.add_load({Load::Kind::kForce, n, rand_vec(2.0), 0.0, 0.0});
    rod.add_load({Load::Kind::kForce, 0, rand_vec(2.0), 0.5, 0.0});  // not started
    rod.add_load({Load::Kind::kTorque, trial % n, rand_vec(0.1), 0.2, 0.2});
    rod.add_load({Load::Kind::kTorque, n - 1, rand_vec(0.1), 0.0, 1.0});
    rod.add_node_drive({NodeDrive::Kind::kFixed, 0, rod.positions()[0]});
    expect_forces_match(rod, t, Vec3(0.3, -1.0, -9.81));
  }
  std::printf("largest relative difference: forces %.2e, torques %.2e\n", max_rel_f, max_rel_tau);
}

// A rod hanging from a ghost-frame clamp, the other end dragged and spun by drives, with loads:
// a few hundred steps stay on the reference trajectory (differences are rounding only).
TEST_F(StepRegression, StepsFollowTheReferenceTrajectory) {
  const int n = 12;
  Rod rod = wavy_rod(n, 1.0);
  rod.ghost_start().active = true;
  rod.ghost_start().frame = rod.orientations()[0];
  rod.ghost_start().uhat = rand_vec(1.0);
  rod.add_node_drive({NodeDrive::Kind::kFixed, 0, rod.positions()[0]});
  NodeDrive moving{NodeDrive::Kind::kVelocity, n, rod.positions()[n], Vec3(0.2, -0.1, 0.3)};
  moving.t_start = 2e-4;
  rod.add_node_drive(moving);
  SegmentDrive spin{SegmentDrive::Kind::kSpin, n - 1, rod.orientations()[n - 1], 3.0};
  rod.add_segment_drive(spin);
  NodeDrive target{NodeDrive::Kind::kTarget, n / 2, rod.positions()[n / 2]};
  target.target = rod.positions()[n / 2] + Vec3(1e-3, 0.0, 0.0);
  rod.add_node_drive(target);
  SegmentDrive turn{SegmentDrive::Kind::kTarget, 3, rod.orientations()[3]};
  turn.target = rod.orientations()[3] * Quat(Eigen::AngleAxisd(0.05, Vec3::UnitX()));
  rod.add_segment_drive(turn);
  rod.add_load({Load::Kind::kForce, n - 2, Vec3(0.0, 0.5, 0.2), 1e-4, 2e-3});
  rod.add_load({Load::Kind::kTorque, 5, Vec3(1e-4, 0.0, 2e-4), 0.0, 1e-3});

  const double h = 0.5 * critical_time_step(rod);
  const Vec3 gravity(0.0, 0.0, -9.81);
  const std::vector<Vec3> x0 = rod.positions();
  const Rod start = rod;
  for (Integrator integ : {Integrator::kSemiImplicitEuler, Integrator::kSplitRotation}) {
    Rod run = start, ref = start;
    const int steps = 400;
    double t = 0.0;
    for (int k = 0; k < steps; ++k, t += h) {
      run.step(t, h, gravity, integ);
      reference_step(&ref, t, h, gravity, integ);
    }
    ASSERT_TRUE(run.finite());
    double ex = 0.0, ev = 0.0, eq = 0.0, ew = 0.0, vmax = 0.0, wmax = 0.0, moved = 0.0;
    for (int i = 0; i <= n; ++i) {
      ex = std::max(ex, (run.positions()[i] - ref.positions()[i]).norm());
      ev = std::max(ev, (run.velocities()[i] - ref.velocities()[i]).norm());
      vmax = std::max(vmax, ref.velocities()[i].norm());
    }
    for (int s = 0; s < n; ++s) {
      eq = std::max(eq, (run.orientations()[s].coeffs() - ref.orientations()[s].coeffs()).norm());
      ew = std::max(ew, (run.angular_velocities()[s] - ref.angular_velocities()[s]).norm());
      wmax = std::max(wmax, ref.angular_velocities()[s].norm());
    }
    for (int i = 0; i <= n; ++i) moved = std::max(moved, (ref.positions()[i] - x0[i]).norm());
    std::printf(
        "%s: %d steps of h = %.3g s: |dx| %.2e m, |dv| %.2e (max v %.2e), |dq| %.2e, "
        "|dw| %.2e (max w %.2e), moved %.2e m\n",
        integ == Integrator::kSplitRotation ? "split rotation" : "semi-implicit Euler", steps, h,
        ex, ev, vmax, eq, ew, wmax, moved);
    const double len = 0.5;
    EXPECT_LE(ex, 1e-9 * len);
    EXPECT_LE(ev, 1e-9 * vmax);
    EXPECT_LE(eq, 1e-9);
    EXPECT_LE(ew, 1e-9 * wmax);
    // The run is not trivial: the rod moved and the drives acted.
    EXPECT_GT(moved, 1e-4);
    EXPECT_NEAR(run.positions()[n / 2].x(), target.target.x(), 1e-15);
  }
}

// Rod::integrate after Rod::compute_forces (the path of a world with contacts) is the second half
// of Rod::step: the same state to the last bit, for either integrator.
TEST_F(StepRegression, IntegrateAfterComputeForcesIsTheStep) {
  const int n = 9;
  Rod start = wavy_rod(n, 1.0);
  start.ghost_start().active = true;
  start.ghost_start().frame = start.orientations()[0];
  start.add_node_drive({NodeDrive::Kind::kFixed, 0, start.positions()[0]});
  start.add_segment_drive({SegmentDrive::Kind::kSpin, n - 1, start.orientations()[n - 1], 3.0});
  const double h = 0.5 * critical_time_step(start);
  const Vec3 gravity(0.0, 0.0, -9.81);
  for (Integrator integ : {Integrator::kSemiImplicitEuler, Integrator::kSplitRotation}) {
    Rod a = start, b = start;
    for (int k = 0; k < 50; ++k) {
      a.step(k * h, h, gravity, integ);
      b.compute_forces(k * h, gravity);
      b.integrate(k * h, h, integ);
    }
    for (int i = 0; i <= n; ++i) {
      EXPECT_EQ(a.positions()[i], b.positions()[i]);
      EXPECT_EQ(a.velocities()[i], b.velocities()[i]);
    }
    for (int s = 0; s < n; ++s) {
      EXPECT_EQ(a.orientations()[s].coeffs(), b.orientations()[s].coeffs());
      EXPECT_EQ(a.angular_velocities()[s], b.angular_velocities()[s]);
    }
  }
}

// Rods longer than one block of Rod::step (1024 segments) cross block edges, where forces,
// torques, loads and the lagging integration hand over between blocks: loads, drives and a ghost
// clamp sit on and next to the edges.
TEST_F(StepRegression, LongRodAcrossBlockEdgesFollowsTheReference) {
  const int n = 2600;
  Rod rod = wavy_rod(n, 1.0);
  rod.ghost_start().active = true;
  rod.ghost_start().frame = rod.orientations()[0];
  rod.ghost_end().active = true;
  rod.ghost_end().frame = rod.orientations()[n - 1];
  rod.add_node_drive({NodeDrive::Kind::kFixed, 0, rod.positions()[0]});
  rod.add_node_drive({NodeDrive::Kind::kFixed, n, rod.positions()[n]});
  for (int edge : {1024, 2048}) {
    for (int i : {edge - 1, edge, edge + 1}) {
      rod.add_load({Load::Kind::kForce, i, rand_vec(0.5), 0.0, 1e-5});
      rod.add_load({Load::Kind::kTorque, i, rand_vec(1e-4), 0.0, 0.0});
    }
  }
  rod.add_segment_drive({SegmentDrive::Kind::kSpin, 1024, rod.orientations()[1024], 3.0});
  const Vec3 x2048 = rod.positions()[2048];
  rod.add_node_drive({NodeDrive::Kind::kVelocity, 2048, x2048, Vec3(0.1, 0, 0)});
  const Vec3 gravity(0.0, 0.0, -9.81);
  expect_forces_match(rod, 0.0, gravity);

  const double h = 0.5 * critical_time_step(rod);
  const Rod start = rod;
  for (Integrator integ : {Integrator::kSemiImplicitEuler, Integrator::kSplitRotation}) {
    Rod run = start, ref = start;
    double t = 0.0;
    for (int k = 0; k < 100; ++k, t += h) {
      run.step(t, h, gravity, integ);
      reference_step(&ref, t, h, gravity, integ);
    }
    ASSERT_TRUE(run.finite());
    double ex = 0.0, eq = 0.0;
    for (int i = 0; i <= n; ++i)
      ex = std::max(ex, (run.positions()[i] - ref.positions()[i]).norm());
    for (int s = 0; s < n; ++s)
      eq = std::max(eq, (run.orientations()[s].coeffs() - ref.orientations()[s].coeffs()).norm());
    std::printf("N = %d, 100 steps of h = %.3g s: |dx| %.2e m, |dq| %.2e\n", n, h, ex, eq);
    EXPECT_LE(ex, 1e-9 * 0.5 / n);
    EXPECT_LE(eq, 1e-9);
    EXPECT_NEAR(run.positions()[2048].x(), x2048.x() + 0.1 * t, 1e-12);  // the drive acted
  }
}

// Indices are checked when a drive or load is added, so the step itself never checks them.
TEST_F(StepRegression, OutOfRangeDrivesAndLoadsAreRefused) {
  Rod rod = wavy_rod(5, 0.0);
  EXPECT_THROW(rod.add_load({Load::Kind::kForce, 6, Vec3::UnitX(), 0.0, 0.0}), std::out_of_range);
  EXPECT_THROW(rod.add_load({Load::Kind::kForce, -1, Vec3::UnitX(), 0.0, 0.0}), std::out_of_range);
  EXPECT_THROW(rod.add_load({Load::Kind::kTorque, 5, Vec3::UnitX(), 0.0, 0.0}), std::out_of_range);
  EXPECT_NO_THROW(rod.add_load({Load::Kind::kForce, 5, Vec3::UnitX(), 0.0, 0.0}));
  EXPECT_NO_THROW(rod.add_load({Load::Kind::kTorque, 4, Vec3::UnitX(), 0.0, 0.0}));
  EXPECT_EQ(rod.loads().size(), 2u);
  EXPECT_THROW(rod.add_node_drive({NodeDrive::Kind::kFixed, 6, Vec3::Zero()}), std::out_of_range);
  EXPECT_THROW(rod.add_segment_drive({SegmentDrive::Kind::kFixed, 5, Quat::Identity()}),
               std::out_of_range);
}

}  // namespace
}  // namespace corde
