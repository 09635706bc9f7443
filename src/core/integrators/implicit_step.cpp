#include "corde_sim/integrators/implicit_step.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "corde_sim/linalg/newton.h"
#include "corde_sim/math/so3.h"
#include "corde_sim/model/drag.h"
#include "corde_sim/model/loads.h"

namespace corde {

namespace {

// Restricts unknown u (3 components at 3u) of a to the directions of the projector p: rows and
// columns multiplied by p, the complement (I - p) on the diagonal, so that the solution's
// component lies in p's range and the matrix stays positive definite.
void project_block(BlockTridiag* a, int u, const Mat3& p) {
  // Only the 3x3 blocks in u's rows and columns change (o: u's offset in block k, v: the other
  // item's); the products assign through temporaries, so aliasing is safe.
  const int k = u / 2, o = 3 * (u % 2), v = 3 - o;
  Mat6& d = a->diag[k];
  d.block<3, 3>(o, o) = p * d.block<3, 3>(o, o) * p + (Mat3::Identity() - p);
  d.block<3, 3>(o, v) = p * d.block<3, 3>(o, v);
  d.block<3, 3>(v, o) = d.block<3, 3>(v, o) * p;
  if (k < static_cast<int>(a->lower.size()))
    a->lower[k].middleCols<3>(o) = a->lower[k].middleCols<3>(o) * p;
  if (k > 0) a->lower[k - 1].middleRows<3>(o) = p * a->lower[k - 1].middleRows<3>(o);
}

}  // namespace

void ImplicitEuler::setup_supports(Rod& rod, double t1) {
  const int nn = rod.num_nodes();
  auto& x = rod.positions();
  auto& q = rod.orientations();
  kind_.assign(2 * nn, 0);
  proj_.resize(2 * nn);
  kind_[2 * nn - 1] = 1;  // the unused rotation slot of the last block
  for (const NodeConstraint& c : rod.node_constraints()) {
    const Vec3& a = c.direction;
    const Mat3 aa = a * a.transpose();
    const bool line = c.kind == NodeConstraint::Kind::kLine;
    kind_[2 * c.node] = 2;
    proj_[2 * c.node] = line ? aa : Mat3(Mat3::Identity() - aa);
    Vec3& p = x[c.node];
    p = line ? Vec3(c.point + a * a.dot(p - c.point)) : Vec3(p - a * a.dot(p - c.point));
  }
  for (const SegmentConstraint& c : rod.segment_constraints()) {
    // Rotation about the world axis only: in the body frame of the step's start (which turning
    // about that axis does not change).
    const Vec3 b = q0_[c.segment].conjugate() * c.axis;
    kind_[2 * c.segment + 1] = 2;
    proj_[2 * c.segment + 1] = b * b.transpose();
    const Vec3 th = b * b.dot(what_[c.segment]);
    q[c.segment] = (q0_[c.segment] * so3::exp(th)).normalized();
  }
  for (const NodeDrive& d : rod.node_drives()) {
    x[d.node] = drive_position(d, t1);
    kind_[2 * d.node] = 1;
  }
  for (const SegmentDrive& d : rod.segment_drives()) {
    q[d.segment] = drive_orientation_near(d, t1, q0_[d.segment]);
    kind_[2 * d.segment + 1] = 1;
  }
}

void ImplicitEuler::setup_dissipation(const Rod& rod, double h) {
  (void)h;
  const int nn = rod.num_nodes(), ns = rod.num_segments();
  const Section& sec = rod.section();
  friction_t_ = sec.gamma_t > 0.0;
  friction_r_ = sec.gamma_r > 0.0 && ns > 1;
  drag_on_ = rod.drag().active();
  // Directions and drag coefficients: at the step's start for backward Euler (first order), at
  // the state extrapolated to the step's end for BDF2 (frozen at the start they would leave an
  // O(h) error in the forces, which makes the step first order).
  const std::vector<Vec3>& xd = used_bdf2_ ? xx_ : x0_;
  const std::vector<Vec3>& vd = used_bdf2_ ? vx_ : v0_;
  if (friction_t_ || drag_on_) {
    tangent_.resize(ns);
    chord0_.resize(ns);
    for (int s = 0; s < ns; ++s) {
      const Vec3 d = xd[s + 1] - xd[s];
      const double len = d.norm();
      tangent_[s] = len > 0.0 ? Vec3(d / len) : Vec3::Zero();
      chord0_[s] = tangent_[s].dot(xt_[s + 1] - xt_[s]);  // len for backward Euler
    }
  }
  if (drag_on_) {
    // The explicit force's drag (model/drag.h) with its coefficients held at the velocity vd.
    const double inv_mu = 1.0 / sec.mass_per_length;
    drag_.resize(nn);
    for (int i = 0; i < nn; ++i)
      drag_[i] =
          drag_matrix(node_drag(rod.drag(), xd, i, vd[i], rod.node_section_masses()[i], inv_mu));
  }
}

void ImplicitEuler::setup_loads(const Rod& rod, double t1) {
  const int ns = rod.num_segments();
  forces_.clear();
  torques_.clear();
  for (const Load& l : rod.loads()) {
    const double f = l.scale(t1);
    if (f == 0.0) continue;
    // A follower turned with its segment at the start (BDF2: extrapolated to the end).
    const Vec3 value = load_world(l, f, used_bdf2_ ? qx_ : q0_);
    (l.kind == Load::Kind::kForce ? forces_ : torques_).push_back({l.index, value});
  }
  if (rod.has_external()) {
    for (int i = 0; i < rod.num_nodes(); ++i)
      if (!rod.external_forces()[i].isZero()) forces_.push_back({i, rod.external_forces()[i]});
    for (int s = 0; s < ns; ++s)
      if (!rod.external_torques()[s].isZero()) torques_.push_back({s, rod.external_torques()[s]});
  }
}

double ImplicitEuler::merit(const Rod& rod, const RodSystem& sys, double h) const {
  const int nn = rod.num_nodes(), ns = rod.num_segments();
  const auto& x = rod.positions();
  double phi = sys.energy();
  const double inv_h2 = 1.0 / (h * h), inv_h = 1.0 / h;
  for (int i = 0; i < nn; ++i)
    phi += 0.5 * inv_h2 * rod.node_masses()[i] * (x[i] - xhat_[i]).squaredNorm();
  for (int s = 0; s < ns; ++s) {
    const Vec3 e = theta_[s] - what_[s];
    phi += 0.5 * inv_h2 * e.dot(rod.segment_inertia(s).cwiseProduct(e));
  }
  if (friction_t_) {
    const double gt = rod.section().gamma_t;
    for (int s = 0; s < ns; ++s) {
      const double u = tangent_[s].dot(x[s + 1] - x[s]) - chord0_[s];
      phi += 0.5 * inv_h * gt / rod.rest_lengths()[s] * u * u;
    }
  }
  if (friction_r_) {
    const double gr = rod.section().gamma_r;
    const auto& rest = rod.rest_lengths();
    for (int j = 0; j + 1 < ns; ++j) {
      const Vec3 dw =
          rot0_[j + 1] * (theta_[j + 1] + off_[j + 1]) - rot0_[j] * (theta_[j] + off_[j]);
      phi += 0.5 * inv_h * gr / (0.5 * (rest[j] + rest[j + 1])) * dw.squaredNorm();
    }
  }
  if (drag_on_)
    for (int i = 0; i < nn; ++i) {
      const Vec3 dx = x[i] - xt_[i];
      phi += 0.5 * inv_h * dx.dot(drag_[i] * dx);
    }
  for (const auto& [i, f] : forces_) phi -= f.dot(x[i]);
  // Torques have no potential on the rotations; their work along the step's rotation (as
  // statics takes it) keeps Phi consistent with the gradient.
  for (const auto& [s, tq] : torques_) phi -= tq.dot(rot0_[s] * theta_[s]);
  return phi;
}

void ImplicitEuler::gradient(const Rod& rod, const RodSystem& sys, double h, Eigen::VectorXd* g) {
  const int nn = rod.num_nodes(), ns = rod.num_segments();
  const auto& x = rod.positions();
  const auto& q = rod.orientations();
  for (int s = 0; s < ns; ++s) theta_[s] = so3::log(q0_[s].conjugate() * q[s]);
  sys.gradient(g);
  const double inv_h2 = 1.0 / (h * h), inv_h = 1.0 / h;
  for (int i = 0; i < nn; ++i)
    g->segment<3>(RodSystem::node_index(i)) += inv_h2 * rod.node_masses()[i] * (x[i] - xhat_[i]);
  if (friction_t_) {
    const double gt = rod.section().gamma_t;
    for (int s = 0; s < ns; ++s) {
      const double u = tangent_[s].dot(x[s + 1] - x[s]) - chord0_[s];
      const Vec3 f = (inv_h * gt / rod.rest_lengths()[s] * u) * tangent_[s];
      g->segment<3>(RodSystem::node_index(s + 1)) += f;
      g->segment<3>(RodSystem::node_index(s)) -= f;
    }
  }
  if (drag_on_)
    for (int i = 0; i < nn; ++i)
      g->segment<3>(RodSystem::node_index(i)) += inv_h * (drag_[i] * (x[i] - xt_[i]));
  for (const auto& [i, f] : forces_) g->segment<3>(RodSystem::node_index(i)) -= f;
  // Per segment, the gradient with respect to its total rotation theta, then mapped to the
  // increment at the current iterate.
  gth_.resize(ns);
  for (int s = 0; s < ns; ++s)
    gth_[s] = inv_h2 * rod.segment_inertia(s).cwiseProduct(theta_[s] - what_[s]);
  if (friction_r_) {
    const double gr = rod.section().gamma_r;
    const auto& rest = rod.rest_lengths();
    for (int j = 0; j + 1 < ns; ++j) {
      const Vec3 dw =
          (inv_h * gr / (0.5 * (rest[j] + rest[j + 1]))) *
          (rot0_[j + 1] * (theta_[j + 1] + off_[j + 1]) - rot0_[j] * (theta_[j] + off_[j]));
      gth_[j + 1] += rot0_[j + 1].transpose() * dw;
      gth_[j] -= rot0_[j].transpose() * dw;
    }
  }
  for (const auto& [s, tq] : torques_) gth_[s] -= rot0_[s].transpose() * tq;
  for (int s = 0; s < ns; ++s)
    g->segment<3>(RodSystem::segment_index(s)) += so3::inv_right_jacobian_t(theta_[s], gth_[s]);
}

void ImplicitEuler::project_gradient(Eigen::VectorXd* g) const {
  for (int u = 0; u < static_cast<int>(kind_.size()); ++u) {
    if (kind_[u] == 1) g->segment<3>(3 * u).setZero();
    if (kind_[u] == 2) g->segment<3>(3 * u) = proj_[u] * g->segment<3>(3 * u);
  }
}

void ImplicitEuler::assemble(const Rod& rod, const RodSystem& sys, double h) {
  const int nn = rod.num_nodes(), ns = rod.num_segments();
  const double inv_h2 = (1.0 + shift_) / (h * h), inv_h = 1.0 / h;
  sys.hessian(&a_);
  for (int i = 0; i < nn; ++i)
    a_.diag[i].topLeftCorner<3, 3>().diagonal().array() += inv_h2 * rod.node_masses()[i];
  for (int s = 0; s < ns; ++s)
    a_.diag[s].bottomRightCorner<3, 3>().diagonal() += inv_h2 * rod.segment_inertia(s);
  // Written straight into the 6x6 blocks (model/rod_system.h): node s at offset 0 of block s,
  // segment s at offset 3, lower[s] the block (s + 1, s).
  if (friction_t_) {
    const double gt = rod.section().gamma_t;
    for (int s = 0; s < ns; ++s) {
      const Mat3 m = (inv_h * gt / rod.rest_lengths()[s]) * (tangent_[s] * tangent_[s].transpose());
      a_.diag[s].topLeftCorner<3, 3>() += m;
      a_.diag[s + 1].topLeftCorner<3, 3>() += m;
      a_.lower[s].topLeftCorner<3, 3>() -= m;
    }
  }
  if (friction_r_) {
    const double gr = rod.section().gamma_r;
    const auto& rest = rod.rest_lengths();
    for (int j = 0; j + 1 < ns; ++j) {
      const double c = inv_h * gr / (0.5 * (rest[j] + rest[j + 1]));
      a_.diag[j].bottomRightCorner<3, 3>() += c * (rot0_[j].transpose() * rot0_[j]);
      a_.diag[j + 1].bottomRightCorner<3, 3>() += c * (rot0_[j + 1].transpose() * rot0_[j + 1]);
      a_.lower[j].bottomRightCorner<3, 3>() -= c * (rot0_[j + 1].transpose() * rot0_[j]);
    }
  }
  if (drag_on_)
    for (int i = 0; i < nn; ++i) a_.diag[i].topLeftCorner<3, 3>() += inv_h * drag_[i];
  for (int u = 0; u < static_cast<int>(kind_.size()); ++u) {
    if (kind_[u] == 1)
      for (int c = 0; c < 3; ++c) a_.fix(3 * u + c);
    if (kind_[u] == 2) project_block(&a_, u, proj_[u]);
  }
}

// The residual of a held or constrained item's equation is what its support supplies: for a
// node m (x - x_hat)/h^2 - f, as Rod::apply_drives records it.
void ImplicitEuler::record_reactions(Rod& rod) {
  const auto& q = rod.orientations();
  for (NodeDrive& d : rod.node_drives_) d.reaction = g_.segment<3>(RodSystem::node_index(d.node));
  for (SegmentDrive& d : rod.segment_drives_)
    d.reaction = q[d.segment] * Vec3(g_.segment<3>(RodSystem::segment_index(d.segment)));
  for (NodeConstraint& c : rod.node_constraints_) {
    const Vec3 r = g_.segment<3>(RodSystem::node_index(c.node));
    c.reaction = r - proj_[2 * c.node] * r;
  }
  for (SegmentConstraint& c : rod.segment_constraints_) {
    const Vec3 r = g_.segment<3>(RodSystem::segment_index(c.segment));
    c.reaction = q[c.segment] * Vec3(r - proj_[2 * c.segment + 1] * r);
  }
  // A ghost clamp's moment is its element's torque on the end segment (an elastic term of the
  // residual, not a support's unknown): at the step's end, with the frame at the step's end.
  rod.record_ghost_reactions();
}

void ImplicitEuler::remember_end(const Rod& rod) {
  xe_ = rod.positions();
  qe_ = rod.orientations();
  ve_ = rod.velocities();
  we_ = rod.angular_velocities();
}

bool ImplicitEuler::history_usable(const Rod& rod, double h) const {
  if (!have_history_ || h != h_last_ || drives_ != drives_last_) return false;
  if (rod.positions() != xe_ || rod.velocities() != ve_ || rod.angular_velocities() != we_)
    return false;
  const auto& q = rod.orientations();
  if (q.size() != qe_.size()) return false;
  for (size_t s = 0; s < q.size(); ++s)
    if (q[s].coeffs() != qe_[s].coeffs()) return false;
  return true;
}

// Newton iterations on the shared solver (linalg/newton.h), with this step's matrices, chord
// iterations and line search settings (its arithmetic as the step always had it).
class ImplicitEuler::Iterations final : public NewtonProblem {
 public:
  Iterations(ImplicitEuler* e, Rod* rod, RodSystem* sys, double h, double lc, double tolerance,
             ImplicitResult* res)
      : e_(*e),
        rod_(*rod),
        sys_(*sys),
        x_(rod->positions()),
        q_(rod->orientations()),
        h_(h),
        lc_(lc),
        tolerance_(tolerance),
        res_(*res) {}

  // |[f; tau / lc]|, the residual's scaled norm.
  double norm_scaled(const Eigen::VectorXd& g) const {
    double r2 = 0.0;
    for (int k = 0; k < rod_.num_nodes(); ++k) {
      r2 += g.segment<3>(6 * k).squaredNorm();
      r2 += (g.segment<3>(6 * k + 3) / lc_).squaredNorm();
    }
    return std::sqrt(r2);
  }
  // The gradient, kept also before the supports' projection (the reactions at the end).
  void full_gradient(Eigen::VectorXd* g, Eigen::VectorXd* raw) {
    e_.gradient(rod_, sys_, h_, g);
    theta_stale_ = false;
    *raw = *g;
    e_.project_gradient(g);
  }
  void set_theta() {
    for (size_t s = 0; s < q_.size(); ++s) e_.theta_[s] = so3::log(e_.q0_[s].conjugate() * q_[s]);
    theta_stale_ = false;
  }

  double residual_norm() override { return norm_scaled(e_.g_); }
  Check check(double residual) override {
    res_.residual = residual;
    if (residual <= tolerance_) {
      res_.converged = true;
      return Check::kConverged;
    }
    // A kept factorisation that did not cut the residual to a quarter is no longer worth
    // keeping, and Newton iterations factorise afresh until a step converges in one or none
    // (the rod moves too much for chord iterations; the contact response may still keep one).
    if (last_kept_ && residual > 0.25 * last_residual_) {
      e_.factored_ = e_.have_factor_ = false;
      e_.chord_ok_ = false;
    }
    last_residual_ = residual;
    return Check::kContinue;
  }
  bool direction(int attempt, double* slope) override {
    (void)attempt;
    kept_ = e_.chord_ok_ && e_.factor_reusable(rod_);
    ++res_.iterations;
    // The exact Hessian converges quadratically; where it is not positive definite (frames
    // sheared against their chords, a compressed chord) the definite variant stands in for
    // this iteration.
    if (!kept_) {
      sys_.definite = false;
      bool ok = e_.refactor(rod_, sys_, h_);
      // Indefinite (a compressed rod buckling, typically where it lands): the exact Hessian with
      // its inertia terms scaled up by 1 + tau, the smallest tau of a geometric series that makes
      // it definite (starting below the last one that did), keeps the rest of its curvature; the
      // definite variant drops the compressed terms' curvature everywhere and converges slowly.
      for (double tau = std::max(kMinShift, 0.25 * shift_); !ok && tau <= kMaxShift; tau *= 4.0) {
        e_.shift_ = tau;
        ok = e_.refactor(rod_, sys_, h_);
        if (ok) shift_ = tau;
      }
      e_.shift_ = 0.0;
      if (!ok) {
        sys_.definite = true;
        if (!e_.refactor(rod_, sys_, h_)) {  // cannot fail with the definite variant
          e_.factored_ = false;
          return false;
        }
      }
    }
    e_.factored_ = true;
    last_kept_ = kept_;
    e_.d_ = -e_.g_;
    e_.solver_.solve(&e_.d_);
    if (kept_) e_.project_gradient(&e_.d_);  // the supports' directions may have turned since
    *slope = e_.g_.dot(e_.d_);
    e_.xs_ = x_;
    e_.qk_ = q_;
    return true;
  }
  Retry rejected(int attempt) override {
    (void)attempt;
    x_ = e_.xs_;
    q_ = e_.qk_;
    set_theta();
    if (kept_) {  // a stale direction: try again with the matrix at this iterate
      e_.factored_ = e_.have_factor_ = false;
      last_kept_ = false;
      e_.chord_ok_ = false;
      return Retry::kNextIteration;
    }
    full_gradient(&e_.g_, &e_.g_raw_);
    return Retry::kStop;
  }

  // Along the retraction: positions added, rotations composed in the body frame.
  void move(double alpha) override {
    for (size_t i = 0; i < x_.size(); ++i) x_[i] = e_.xs_[i] + alpha * e_.d_.segment<3>(6 * i);
    for (size_t s = 0; s < q_.size(); ++s)
      q_[s] = (e_.qk_[s] * so3::exp(alpha * e_.d_.segment<3>(6 * s + 3))).normalized();
    theta_stale_ = true;
  }
  double merit(double alpha) override {
    (void)alpha;
    if (theta_stale_) set_theta();
    return e_.merit(rod_, sys_, h_);
  }
  // Phi at the iterate and the magnitude of the terms it sums (for telling its changes from
  // round-off), evaluated only once a step needs them.
  void base_merit(MeritAtIterate* m) override {
    x_.swap(e_.xs_);
    q_.swap(e_.qk_);
    set_theta();
    m->phi = e_.merit(rod_, sys_, h_);
    const double scale = std::abs(m->phi) + std::abs(sys_.energy()) + 1e-300;
    m->noise = 1e3 * std::numeric_limits<double>::epsilon() * scale;
    x_.swap(e_.xs_);
    q_.swap(e_.qk_);
    set_theta();
  }
  double trial_residual() override {
    full_gradient(&e_.g_trial_, &e_.g_raw_trial_);
    return norm_scaled(e_.g_trial_);
  }
  void accept_trial() override {
    e_.g_.swap(e_.g_trial_);
    e_.g_raw_.swap(e_.g_raw_trial_);
  }

 private:
  ImplicitEuler& e_;
  Rod& rod_;
  RodSystem& sys_;
  std::vector<Vec3>& x_;
  std::vector<Quat>& q_;
  double h_, lc_, tolerance_;
  ImplicitResult& res_;
  double last_residual_ = 0.0;
  bool last_kept_ = false;  // the last iteration ran on a kept factorisation
  bool kept_ = false;
  bool theta_stale_ = false;
  double shift_ = 0.0;  // the last shift that made the exact Hessian definite in this step
  static constexpr double kMinShift = 1e-3, kMaxShift = 1e3;
};

ImplicitResult ImplicitEuler::step(Rod& rod, double t, double h, const Vec3& gravity,
                                   const std::vector<Vec3>* predicted,
                                   const std::vector<Vec3>* predicted_torques) {
  const int nn = rod.num_nodes(), ns = rod.num_segments();
  auto& x = rod.positions();
  auto& q = rod.orientations();
  auto& v = rod.velocities();
  auto& w = rod.angular_velocities();
  // The drives' items and kinds: a grasp taken or let go restarts BDF2.
  drives_.clear();
  for (const NodeDrive& d : rod.node_drives())
    drives_.push_back(4 * d.node + static_cast<int>(d.kind));
  for (const SegmentDrive& d : rod.segment_drives())
    drives_.push_back(-4 * d.segment - 1 - static_cast<int>(d.kind));
  // BDF2 needs the last step's start state as x^{n-1}; without a usable history (the first
  // step, a new h such as the guard's retry at half the step, a state changed from outside: a
  // reset, a configure, a teleport) this step is one backward-Euler step, from which BDF2 starts.
  // Contacts acted on the rod in the last step (their impulses are the prediction): their velocity
  // jumps are not smooth in time, and BDF2's memory of the positions before them would carry the
  // motion into the contact (the energy rises), so the step is a backward Euler step. Contacts
  // are first order in time either way.
  bool touching = false;
  if (predicted)
    for (const Vec3& p : *predicted) touching = touching || !p.isZero();
  const bool second = bdf2_ && !touching && !force_first_ && history_usable(rod, h);
  force_first_ = false;
  used_bdf2_ = second;
  if (second) {
    xp_.swap(x0_);
    qp_.swap(q0_);
    vp_.swap(v0_);
    wp_.swap(w0_);
  }
  x0_ = x;
  q0_ = q;
  v0_ = v;
  w0_ = w;
  beta_ = second ? 2.0 * h / 3.0 : h;
  xt_.resize(nn);
  off_.resize(ns);
  xhat_.resize(nn);
  what_.resize(ns);
  theta_.resize(ns);
  for (int i = 0; i < nn; ++i) {
    xt_[i] = second ? Vec3((4.0 * x[i] - xp_[i]) / 3.0) : x[i];
    const Vec3 vt = second ? Vec3((4.0 * v[i] - vp_[i]) / 3.0) : v[i];
    xhat_[i] = xt_[i] + beta_ * vt;
  }
  for (int s = 0; s < ns; ++s) {
    off_[s] = second ? Vec3(so3::log(q0_[s].conjugate() * qp_[s]) / 3.0) : Vec3::Zero();
    const Vec3 wt = second ? Vec3((4.0 * w[s] - wp_[s]) / 3.0) : w[s];
    what_[s] = beta_ * wt - off_[s];
  }
  if (second) {  // linear extrapolation to t + h, for the directions held over the step
    xx_.resize(nn);
    vx_.resize(nn);
    qx_.resize(ns);
    for (int i = 0; i < nn; ++i) {
      xx_[i] = 2.0 * x[i] - xp_[i];
      vx_[i] = 2.0 * v[i] - vp_[i];
    }
    for (int s = 0; s < ns; ++s) qx_[s] = (q0_[s] * so3::exp(-3.0 * off_[s])).normalized();
  }
  factored_ = false;
  const double hs = h;  // the world's step (drives, loads and the new time use it)
  h = beta_;            // the step the minimisation takes

  // Predictor: free items move on with their velocities; supports are set or projected.
  const double t1 = t + hs;
  for (int i = 0; i < nn; ++i) x[i] = xhat_[i];
  for (int s = 0; s < ns; ++s) q[s] = (q0_[s] * so3::exp(what_[s])).normalized();
  setup_supports(rod, t1);
  for (GhostFrame* gf : {&rod.ghost_start(), &rod.ghost_end()})
    if (gf->active && gf->motion) gf->frame = ghost_frame_at(*gf, t1);
  // Per segment the map from its rotation over the step to the world, for torques (their work
  // along the step's rotation) and rotational friction (world angular velocities): R^n for
  // backward Euler; for BDF2 R_p J_r(theta_p) at the extrapolated rotation theta_p = -xi, so
  // that after the increment's mapping J_r^-T(theta) they act in the frame of the step's end to
  // O(h^2) (with R^n they would act in the middle of the step, an O(h) error).
  rot0_.resize(ns);
  for (int s = 0; s < ns; ++s)
    rot0_[s] = second ? Mat3(qx_[s].toRotationMatrix() * so3::right_jacobian(-3.0 * off_[s]))
                      : Mat3(q0_[s].toRotationMatrix());
  setup_dissipation(rod, h);
  setup_loads(rod, t1);
  predicted_.clear();
  if (predicted && static_cast<int>(predicted->size()) == nn) {
    predicted_ = *predicted;
    for (int i = 0; i < nn; ++i)
      if (!predicted_[i].isZero()) forces_.push_back({i, predicted_[i] / h});
  }
  predicted_torques_.clear();
  if (predicted_torques && static_cast<int>(predicted_torques->size()) == ns) {
    predicted_torques_ = *predicted_torques;
    for (int s = 0; s < ns; ++s)
      if (!predicted_torques_[s].isZero()) torques_.push_back({s, predicted_torques_[s] / h});
  }

  RodSystem sys{&rod, gravity, t1};
  sys.terms = kAllTerms & ~kLoadTerm;  // loads: setup_loads, held over the step
  double lc = 0.0, ref = 0.0;
  for (double l : rod.rest_lengths()) lc += l / ns;
  for (int i = 0; i < nn; ++i) ref += rod.node_masses()[i] * (gravity.norm() + v0_[i].norm() / h);
  for (int s = 0; s < ns; ++s) ref += rod.segment_inertia(s).maxCoeff() * w[s].norm() / (h * lc);
  for (const auto& f : forces_) ref += f.second.norm();
  for (const auto& tq : torques_) ref += tq.second.norm() / lc;
  // Residual noise of the forces: strains carry round-off of eps (1 + |x| / l).
  double xmax = 0.0;
  for (const Vec3& p : x) xmax = std::max(xmax, p.cwiseAbs().maxCoeff());
  const Section& sec = rod.section();
  const double floor = 10.0 * std::numeric_limits<double>::epsilon() * std::sqrt(6.0 * nn) *
                       (1.0 + xmax / lc) *
                       (sec.stretch + sec.kappa + (sec.bend + sec.twist) / (lc * lc));
  ImplicitResult res;
  res.reference = ref;
  // The predicted contact forces are known only as well as the contact solve resolves them: a
  // residual below that share of them is the contact solve's noise, not the step's error.
  double predicted_scale = 0.0;
  for (const Vec3& p : predicted_) predicted_scale += p.norm() / h;
  for (const Vec3& t : predicted_torques_) predicted_scale += t.norm() / (h * lc);
  const double tolerance =
      std::max({opt_.tolerance * ref, floor, opt_.prediction_tolerance * predicted_scale});
  // Loads whose size overflows (a force of 1e200 N: |F|^2 is infinite) would make the tolerance
  // infinite and the step "converge" without moving: no step can meet them.
  const bool finite_loads = std::isfinite(ref);
  Iterations iterations(this, &rod, &sys, h, lc, tolerance, &res);
  iterations.full_gradient(&g_, &g_raw_);
  // A full step that cuts the residual to a quarter is taken without Phi (the common case, and
  // Newton's near the solution): Phi, an energy evaluation at both ends, is needed only where the
  // step may overshoot.
  NewtonOptions newton;
  newton.max_iterations = opt_.max_iterations;
  newton.line_search.max_trials = 30;
  newton.line_search.full_step_cut = 0.25;
  if (finite_loads) newton_solve(&iterations, newton);
  if (!res.converged) {
    res.residual = iterations.norm_scaled(g_);
    res.converged = res.residual <= tolerance;
  }
  // Forces whose round-off exceeds a thousandth of the loads cannot resolve the motion (a
  // stiffness beyond double precision at this resolution): the step would "converge" without
  // moving. Reported as not converged, with that floor as the residual. The loads are taken as at
  // least the rod's weight under 1 g: a rod at rest and unloaded (no gravity, a load ramped from
  // zero) rightly stays put, while a stiffness whose round-off outweighs the rod is still refused.
  double weight = 0.0;
  for (double m : rod.node_masses()) weight += 9.81 * m;
  if (floor > 1e-3 * std::max(ref, weight)) {
    res.converged = false;
    res.residual = std::max(res.residual, floor);
  }
  if (finite_loads && res.converged && res.iterations <= 1) chord_ok_ = true;  // calm again
  if (!finite_loads) {
    res.converged = false;
    res.residual = std::numeric_limits<double>::infinity();
    res.reference = 1.0;
  }
  // Reactions from the unprojected residual (the gradient at the final iterate, as kept).
  g_raw_.swap(g_);
  record_reactions(rod);
  g_raw_.swap(g_);
  for (int i = 0; i < nn; ++i) v[i] = (x[i] - xt_[i]) / h;
  for (int s = 0; s < ns; ++s) w[s] = (theta_[s] + off_[s]) / h;
  // Drives other than targets give their own velocities (as Rod::step's drives do); a target's
  // is the step's.
  for (const NodeDrive& d : rod.node_drives())
    if (d.kind != NodeDrive::Kind::kTarget) v[d.node] = drive_state(d, t1, h, x[d.node]).velocity;
  for (const SegmentDrive& d : rod.segment_drives())
    if (d.kind != SegmentDrive::Kind::kTarget) {
      Vec3 ww;  // in the body frame the step left the segment in
      drive_orientation(d, t1, &ww);
      w[d.segment] = q[d.segment].conjugate() * ww;
    }
  x_free_ = x;
  q_free_ = q;
  v_free_ = v;
  w_free_ = w;
  have_history_ = bdf2_;
  if (bdf2_) {
    h_last_ = hs;
    drives_last_ = drives_;
    remember_end(rod);
  }
  return res;
}

ImplicitResult ImplicitEuler::restep_first_order(Rod& rod, double t, double h,
                                                 const Vec3& gravity) {
  rod.positions() = x0_;
  rod.orientations() = q0_;
  rod.velocities() = v0_;
  rod.angular_velocities() = w0_;
  force_first_ = true;
  return step(rod, t, h, gravity);
}

bool ImplicitEuler::ensure_factor(const Rod& rod, bool exact_ok) {
  // A shifted factorisation (Iterations::direction) is not the step's linearisation.
  if (factored_ && !factor_shifted_ && (factor_definite_ || exact_ok)) return true;
  // Converged without a Newton iteration: the kept factorisation if it still stands for the
  // matrix at the result, else one at the result.
  if (factor_definite_ && factor_reusable(rod)) return factored_ = true;
  RodSystem sys{&rod, Vec3::Zero(), 0.0};
  sys.definite = true;
  sys.terms = kStretchTerm | kCouplingTerm | kBendTwistTerm;
  factored_ = refactor(rod, sys, beta_);
  return factored_;
}

bool ImplicitEuler::refactor(const Rod& rod, const RodSystem& sys, double h) {
  assemble(rod, sys, h);
  ++factorisations_;
  have_factor_ = solver_.factor(a_);
  factor_definite_ = sys.definite;
  factor_shifted_ = shift_ > 0.0;
  factor_beta_ = h;
  factor_x_ = rod.positions();
  factor_q_ = rod.orientations();
  factor_kind_ = kind_;
  factor_proj_ = proj_;
  parameters(rod, &factor_params_);
  return have_factor_;
}

void ImplicitEuler::parameters(const Rod& rod, std::vector<double>* out) {
  const Section& c = rod.section();
  const Drag& d = rod.drag();
  out->assign({c.radius, c.bend, c.twist, c.stretch, c.kappa, c.gamma_t, c.gamma_r,
               c.mass_per_length, c.inertia_bend, c.inertia_twist, d.linear_normal,
               d.linear_tangential, d.quadratic_normal, d.quadratic_tangential,
               rod.rotational_inertia_scale(), rod.ghost_start().active ? 1.0 : 0.0,
               rod.ghost_end().active ? 1.0 : 0.0});
  out->insert(out->end(), rod.rest_lengths().begin(), rod.rest_lengths().end());
  out->insert(out->end(), rod.node_masses().begin(), rod.node_masses().end());
  for (const Vec3& u : rod.rest_strains()) out->insert(out->end(), u.data(), u.data() + 3);
  // Inertias that differ from the section's (a plug, a denser stretch: rod.h).
  if (!rod.added_segment_inertias().empty() || !rod.segment_mass_scale().empty())
    for (int s = 0; s < rod.num_segments(); ++s) {
      const Vec3 in = rod.segment_inertia(s);
      out->insert(out->end(), in.data(), in.data() + 3);
    }
  // The clamps' ghost frames and rest strains enter the bending blocks (a turning clamp changes
  // them at every step).
  for (const GhostFrame* g : {&rod.ghost_start(), &rod.ghost_end()})
    if (g->active) {
      out->insert(out->end(), g->frame.coeffs().data(), g->frame.coeffs().data() + 4);
      out->insert(out->end(), g->uhat.data(), g->uhat.data() + 3);
    }
  // Quadratic drag's matrix grows with the speed at the step's start: any change of the
  // velocities makes a new one.
  if (d.quadratic_normal > 0.0 || d.quadratic_tangential > 0.0)
    for (const Vec3& v : rod.velocities()) out->insert(out->end(), v.data(), v.data() + 3);
}

bool ImplicitEuler::factor_reusable(const Rod& rod) {
  const double limit = opt_.reuse_factor;
  if (!(limit > 0.0) || !have_factor_ || factor_shifted_ || beta_ != factor_beta_ ||
      kind_ != factor_kind_)
    return false;
  const auto& x = rod.positions();
  const auto& q = rod.orientations();
  if (x.size() != factor_x_.size() || q.size() != factor_q_.size()) return false;
  parameters(rod, &params_);  // a configure may have changed the material, not the shape
  if (params_ != factor_params_) return false;
  for (size_t u = 0; u < kind_.size(); ++u)
    if (kind_[u] == 2 && (proj_[u] - factor_proj_[u]).cwiseAbs().maxCoeff() > limit) return false;
  // sin of half the angle between two orientations, and an element's turn as its chord's change
  // over its rest length (both about the angle for small angles).
  const double half = 0.5 * limit;
  const auto& rest = rod.rest_lengths();
  for (size_t s = 0; s < q.size(); ++s) {
    if ((factor_q_[s].conjugate() * q[s]).vec().norm() > half) return false;
    if (((x[s + 1] - x[s]) - (factor_x_[s + 1] - factor_x_[s])).norm() > limit * rest[s])
      return false;
  }
  return true;
}

void ImplicitEuler::solve_impulses(const std::vector<Vec3>& impulses,
                                   const std::vector<Vec3>* torque_impulses, bool totals) {
  const double h = beta_;
  const int nn = static_cast<int>(kind_.size() / 2);
  z_.setZero(6 * nn);
  for (int i = 0; i < nn; ++i) z_.segment<3>(6 * i) = impulses[i] / h;
  if (totals && !predicted_.empty())
    for (int i = 0; i < nn; ++i) z_.segment<3>(6 * i) -= predicted_[i] / h;
  // A torque T / h held over the step enters as the loads' torques do (gradient()): in the frame
  // of the rotation over the step, mapped to the increment at the step's result.
  for (int s = 0; s + 1 < nn; ++s) {
    Vec3 t = torque_impulses ? (*torque_impulses)[s] : Vec3::Zero();
    if (totals && !predicted_torques_.empty()) t -= predicted_torques_[s];
    if (!t.isZero())
      z_.segment<3>(6 * s + 3) +=
          so3::inv_right_jacobian_t(theta_[s], rot0_[s].transpose() * t) / h;
  }
  project_gradient(&z_);
  rhs_ = z_;
  solver_.solve(&z_);
  project_gradient(&z_);
}

bool ImplicitEuler::response_bounded(const Rod& rod) const {
  // With A >= M/h^2 (the definite variant) z^T M z / h^2 <= z^T A z = b . z. The exact matrix may
  // have a direction where it is far below that (near singular): a response along it would be
  // huge. Twice the bound is allowed (the exact one is the better linearisation elsewhere).
  const int nn = rod.num_nodes(), ns = rod.num_segments();
  double kinetic = 0.0;
  for (int i = 0; i < nn; ++i) kinetic += rod.node_masses()[i] * z_.segment<3>(6 * i).squaredNorm();
  for (int s = 0; s < ns; ++s)
    kinetic +=
        z_.segment<3>(6 * s + 3).dot(rod.segment_inertia(s).cwiseProduct(z_.segment<3>(6 * s + 3)));
  return std::isfinite(kinetic) && kinetic / (beta_ * beta_) <= 2.0 * rhs_.dot(z_);
}

bool ImplicitEuler::solve_response(const Rod& rod, const std::vector<Vec3>& impulses,
                                   const std::vector<Vec3>* torque_impulses, bool totals) {
  // The factorisation of the last Newton iteration, exact or definite, when it answers within the
  // bound; else the definite variant at the step's result.
  if (!ensure_factor(rod, true)) return false;
  solve_impulses(impulses, torque_impulses, totals);
  if (factor_definite_ || response_bounded(rod)) return true;
  if (!ensure_factor(rod, false)) return false;
  solve_impulses(impulses, torque_impulses, totals);
  return true;
}

void ImplicitEuler::response(const Rod& rod, const std::vector<Vec3>& impulses,
                             std::vector<Vec3>* dv, const std::vector<Vec3>* torque_impulses) {
  const int nn = rod.num_nodes();
  const double h = beta_;
  dv->assign(nn, Vec3::Zero());
  if (!solve_response(rod, impulses, torque_impulses, false)) return;
  for (int i = 0; i < nn; ++i) (*dv)[i] = z_.segment<3>(6 * i) / h;
}

bool ImplicitEuler::node_compliance(const Rod& rod, std::vector<Mat3>* diag,
                                    std::vector<Mat3>* lower) {
  if (!ensure_factor(rod, true) || !have_factor_) return false;
  if (inverse_of_ != factorisations_) {
    solver_.selected_inverse(&inv_diag_, &inv_lower_);
    inverse_of_ = factorisations_;
  }
  const int nn = rod.num_nodes();
  const double s = 1.0 / (beta_ * beta_);
  // The projection of each node's increments (held: none; constrained: proj_).
  auto project = [&](int i, const Mat3& m, bool left) -> Mat3 {
    const signed char k = kind_[2 * i];
    if (k == 1) return Mat3::Zero();
    if (k == 2) return left ? Mat3(proj_[2 * i] * m) : Mat3(m * proj_[2 * i]);
    return m;
  };
  diag->resize(nn);
  lower->resize(std::max(0, nn - 1));
  for (int i = 0; i < nn; ++i) {
    (*diag)[i] = project(i, project(i, s * inv_diag_[i].topLeftCorner<3, 3>(), true), false);
    if (i + 1 < nn)
      (*lower)[i] =
          project(i + 1, project(i, s * inv_lower_[i].topLeftCorner<3, 3>(), false), true);
  }
  return true;
}

void ImplicitEuler::respond(Rod& rod, const std::vector<Vec3>& impulses,
                            const std::vector<Vec3>* torque_impulses) {
  const int nn = rod.num_nodes(), ns = rod.num_segments();
  const double h = beta_;
  auto& x = rod.positions();
  auto& q = rod.orientations();
  auto& v = rod.velocities();
  auto& w = rod.angular_velocities();
  x = x_free_;
  q = q_free_;
  v = v_free_;
  w = w_free_;
  if (solve_response(rod, impulses, torque_impulses, true)) {
    for (int i = 0; i < nn; ++i) {
      if (kind_[2 * i] == 1) continue;
      x[i] += z_.segment<3>(6 * i);
      v[i] = (x[i] - xt_[i]) / h;
    }
    for (int s = 0; s < ns; ++s) {
      if (kind_[2 * s + 1] == 1) continue;
      q[s] = (q[s] * so3::exp(z_.segment<3>(6 * s + 3))).normalized();
      w[s] = (so3::log(q0_[s].conjugate() * q[s]) + off_[s]) / h;
    }
  }
  if (bdf2_) remember_end(rod);
}

}  // namespace corde
