#include "corde_sim/implicit_step.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace corde {

namespace {

Quat exp_body(const Vec3& theta) {
  const double a = theta.norm();
  if (a < 1e-300) return Quat::Identity();
  return Quat(Eigen::AngleAxisd(a, theta / a));
}

// Rotation vector of the unit quaternion r (the shorter way round).
Vec3 log_body(const Quat& r) {
  const double s = r.w() < 0.0 ? -1.0 : 1.0;
  const Vec3 v = s * r.vec();
  const double n = v.norm();
  if (n < 1e-300) return Vec3::Zero();
  return (2.0 * std::atan2(n, s * r.w()) / n) * v;
}

// J_r^-1(theta)^T y: the gradient of f(log(exp(theta) exp(delta))) at delta = 0 when y = df/dtheta.
Vec3 inv_right_jacobian_t(const Vec3& theta, const Vec3& y) {
  const double a = theta.norm();
  // (1/a^2 - (1 + cos a) / (2 a sin a)), 1/12 + a^2/720 near zero.
  const double c = a < 1e-4 ? 1.0 / 12.0 + a * a / 720.0
                            : 1.0 / (a * a) - (1.0 + std::cos(a)) / (2.0 * a * std::sin(a));
  return y - 0.5 * theta.cross(y) + c * theta.cross(theta.cross(y));
}

}  // namespace

double ImplicitEuler::merit(const Rod& rod, const RodSystem& sys, double h) const {
  double phi = sys.energy();
  const double inv_h2 = 1.0 / (h * h);
  for (int i = 0; i < rod.num_nodes(); ++i)
    phi += 0.5 * inv_h2 * rod.node_masses()[i] * (rod.positions()[i] - xhat_[i]).squaredNorm();
  for (int s = 0; s < rod.num_segments(); ++s) {
    const Vec3 e = log_body(q0_[s].conjugate() * rod.orientations()[s]) - what_[s];
    phi += 0.5 * inv_h2 * e.dot(rod.segment_inertia(s).cwiseProduct(e));
  }
  if (rod.has_external())
    for (int i = 0; i < rod.num_nodes(); ++i)
      phi -= rod.external_forces()[i].dot(rod.positions()[i]);
  // Dead torques have no potential; their work over the step, taken along the rotation from the
  // step's start (as statics does), keeps Phi consistent with the gradient.
  if (sys.terms & kLoadTerm)
    for (const Load& l : rod.loads())
      if (!l.follower && l.kind == Load::Kind::kTorque)
        phi -= sys.load_scale * l.scale(sys.t) *
               l.value.dot(q0_[l.index] *
                           log_body(q0_[l.index].conjugate() * rod.orientations()[l.index]));
  return phi;
}

void ImplicitEuler::gradient(const Rod& rod, const RodSystem& sys, double h, Eigen::VectorXd* g) {
  sys.gradient(g);
  const double inv_h2 = 1.0 / (h * h);
  for (int i = 0; i < rod.num_nodes(); ++i)
    g->segment<3>(RodSystem::node_index(i)) +=
        inv_h2 * rod.node_masses()[i] * (rod.positions()[i] - xhat_[i]);
  for (int s = 0; s < rod.num_segments(); ++s) {
    const Vec3 theta = log_body(q0_[s].conjugate() * rod.orientations()[s]);
    const Vec3 e = theta - what_[s];
    g->segment<3>(RodSystem::segment_index(s)) +=
        inv_right_jacobian_t(theta, inv_h2 * rod.segment_inertia(s).cwiseProduct(e));
  }
  // Dead torques: the gradient of merit()'s work term (their work along the step's rotation),
  // which differs from minus the body torque R^T T at first order in theta; it keeps the line
  // search consistent.
  if (sys.terms & kLoadTerm)
    for (const Load& l : rod.loads()) {
      if (l.follower || l.kind != Load::Kind::kTorque) continue;
      const double f = sys.load_scale * l.scale(sys.t);
      const int s = l.index;
      const Vec3 theta = log_body(q0_[s].conjugate() * rod.orientations()[s]);
      g->segment<3>(RodSystem::segment_index(s)) +=
          f * (rod.orientations()[s].conjugate() * l.value -
               inv_right_jacobian_t(theta, q0_[s].conjugate() * l.value));
    }
  // External forces and torques (grasps, inputs) as dead loads over the step.
  if (rod.has_external()) {
    for (int i = 0; i < rod.num_nodes(); ++i)
      g->segment<3>(RodSystem::node_index(i)) -= rod.external_forces()[i];
    for (int s = 0; s < rod.num_segments(); ++s)
      g->segment<3>(RodSystem::segment_index(s)) -=
          rod.orientations()[s].conjugate() * rod.external_torques()[s];
  }
  for (int j = 0; j < g->size(); ++j)
    if (fixed_[j]) (*g)(j) = 0.0;
}

ImplicitResult ImplicitEuler::step(Rod& rod, double t, double h, const Vec3& gravity) {
  if (!rod.node_constraints().empty() || !rod.segment_constraints().empty())
    throw std::invalid_argument("implicit step: rod '" + rod.name() +
                                "' has line, plane or axis constraints, which it does not handle");
  for (const Load& l : rod.loads())
    if (l.follower)
      throw std::invalid_argument("implicit step: rod '" + rod.name() +
                                  "' has a follower load, which it does not handle");
  const int nn = rod.num_nodes(), ns = rod.num_segments();
  auto& x = rod.positions();
  auto& q = rod.orientations();
  auto& v = rod.velocities();
  auto& w = rod.angular_velocities();
  x0_ = x;
  q0_ = q;
  xhat_.resize(nn);
  what_.resize(ns);
  for (int i = 0; i < nn; ++i) xhat_[i] = x[i] + h * v[i];
  for (int s = 0; s < ns; ++s) what_[s] = h * w[s];

  // Kinematic items at their drives' state at t + h, fixed in the solve; the rest predicted.
  const double t1 = t + h;
  fixed_.assign(6 * nn, 0);
  for (int c = 3; c < 6; ++c) fixed_[6 * ns + c] = 1;  // the unused slot
  for (int i = 0; i < nn; ++i) x[i] = xhat_[i];
  for (int s = 0; s < ns; ++s) q[s] = (q0_[s] * exp_body(what_[s])).normalized();
  for (const NodeDrive& d : rod.node_drives()) {
    x[d.node] = d.kind == NodeDrive::Kind::kTarget ? d.target : drive_position(d, t1);
    for (int c = 0; c < 3; ++c) fixed_[RodSystem::node_index(d.node) + c] = 1;
  }
  for (const SegmentDrive& d : rod.segment_drives()) {
    Quat target =
        d.kind == SegmentDrive::Kind::kTarget ? d.target.normalized() : drive_orientation(d, t1);
    if (target.coeffs().dot(q0_[d.segment].coeffs()) < 0.0) target.coeffs() *= -1.0;
    q[d.segment] = target;
    for (int c = 0; c < 3; ++c) fixed_[RodSystem::segment_index(d.segment) + c] = 1;
  }
  for (GhostFrame* gf : {&rod.ghost_start(), &rod.ghost_end()})
    if (gf->active && gf->motion) gf->frame = ghost_frame_at(*gf, t1);

  RodSystem sys{&rod, gravity, t1};
  sys.definite = true;
  double lc = 0.0, ref = 0.0;
  for (double l : rod.rest_lengths()) lc += l / ns;
  for (int i = 0; i < nn; ++i) ref += rod.node_masses()[i] * (gravity.norm() + v[i].norm() / h);
  for (int s = 0; s < ns; ++s) ref += rod.segment_inertia(s).maxCoeff() * w[s].norm() / (h * lc);
  // Residual noise of the forces: strains carry round-off of eps (1 + |x| / l).
  double xmax = 0.0;
  for (const Vec3& p : x) xmax = std::max(xmax, p.cwiseAbs().maxCoeff());
  const Section& sec = rod.section();
  const double floor = 10.0 * std::numeric_limits<double>::epsilon() * std::sqrt(6.0 * nn) *
                       (1.0 + xmax / lc) *
                       (sec.stretch + sec.kappa + (sec.bend + sec.twist) / (lc * lc));
  ImplicitResult res;
  res.reference = ref;
  const double inv_h2 = 1.0 / (h * h);
  auto norm_scaled = [&](const Eigen::VectorXd& g) {
    double r2 = 0.0;
    for (int k = 0; k < nn; ++k) {
      r2 += g.segment<3>(6 * k).squaredNorm();
      r2 += (g.segment<3>(6 * k + 3) / lc).squaredNorm();
    }
    return std::sqrt(r2);
  };
  gradient(rod, sys, h, &g_);
  double phi = merit(rod, sys, h);
  // Magnitude of the terms Phi sums, for telling its changes from round-off.
  const double phi_scale = std::abs(phi) + std::abs(sys.energy()) + 1e-300;
  for (int it = 0; it < opt_.max_iterations; ++it) {
    res.residual = norm_scaled(g_);
    if (res.residual <= std::max(opt_.tolerance * ref, floor)) {
      res.converged = true;
      break;
    }
    sys.hessian(&a_);
    for (int i = 0; i < nn; ++i)
      a_.diag[i].topLeftCorner<3, 3>().diagonal().array() += inv_h2 * rod.node_masses()[i];
    for (int s = 0; s < ns; ++s)
      a_.diag[s].bottomRightCorner<3, 3>().diagonal() += inv_h2 * rod.segment_inertia(s);
    for (int j = 0; j < 6 * nn; ++j)
      if (fixed_[j]) a_.fix(j);
    ++res.iterations;
    if (!solver_.factor(a_)) break;  // cannot happen with the definite variant and masses > 0
    d_ = -g_;
    solver_.solve(&d_);
    // Backtracking line search (Armijo) on Phi along the retraction.
    const double slope = g_.dot(d_);
    xk_ = x;
    qk_ = q;
    double alpha = 1.0, phi_new = phi;
    bool accepted = false;
    for (int ls = 0; ls < 30; ++ls, alpha *= 0.5) {
      for (int i = 0; i < nn; ++i) x[i] = xk_[i] + alpha * d_.segment<3>(6 * i);
      for (int s = 0; s < ns; ++s)
        q[s] = (qk_[s] * exp_body(alpha * d_.segment<3>(6 * s + 3))).normalized();
      phi_new = merit(rod, sys, h);
      if (!std::isfinite(phi_new)) continue;
      if (phi_new <= phi + 1e-4 * alpha * slope) {
        accepted = true;
        gradient(rod, sys, h, &g_);
        break;
      }
      // Near the solution the change of Phi is lost in its round-off: accept a step that lowers
      // the residual instead.
      if (std::abs(phi_new - phi) <= 1e3 * std::numeric_limits<double>::epsilon() * phi_scale) {
        gradient(rod, sys, h, &g_trial_);
        if (norm_scaled(g_trial_) < res.residual) {
          g_.swap(g_trial_);
          accepted = true;
          break;
        }
      }
    }
    if (!accepted) {
      x = xk_;
      q = qk_;
      gradient(rod, sys, h, &g_);
      break;
    }
    phi = phi_new;
  }
  if (!res.converged) {
    res.residual = norm_scaled(g_);
    res.converged = res.residual <= std::max(opt_.tolerance * ref, floor);
  }
  for (int i = 0; i < nn; ++i) v[i] = (x[i] - x0_[i]) / h;
  for (int s = 0; s < ns; ++s) w[s] = log_body(q0_[s].conjugate() * q[s]) / h;
  // Drives give their own velocities (as Rod::step's drives do).
  for (const NodeDrive& d : rod.node_drives())
    if (d.kind != NodeDrive::Kind::kTarget) drive_position(d, t1, &v[d.node]);
  for (const SegmentDrive& d : rod.segment_drives())
    if (d.kind != SegmentDrive::Kind::kTarget) {
      Vec3 ww;
      drive_orientation(d, t1, &ww);
      w[d.segment] = q[d.segment].conjugate() * ww;
    }
  return res;
}

}  // namespace corde
