#include "corde_sim/statics/statics.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <utility>
#include <vector>

#include "corde_sim/linalg/block_tridiag_sparse.h"
#include "corde_sim/linalg/newton.h"
#include "corde_sim/math/so3.h"
#include "corde_sim/model/loads.h"
#include "corde_sim/model/rod_system.h"
#include "corde_sim/statics/static_hessian.h"
#include "corde_sim/statics/static_sensitivity.h"

namespace corde {
namespace {

// A DOF of block p (node i: p = 2i, segment s: p = 2s + 1) only reaches blocks p - 2 .. p + 2,
// so blocks five apart can be perturbed together.
constexpr int kColours = 5;
constexpr int kReach = 2;
constexpr double kEps = std::numeric_limits<double>::epsilon();

// The unknowns of one rod and the energy, residual and Hessian as functions of them. The rod's
// loads are taken out while it lives (its force computation then holds only internal forces and
// gravity) and added back here with the continuation factor.
class Problem {
 public:
  Problem(Rod& rod, const Vec3& gravity, double t, const StaticOptions& options)
      : rod_(rod), gravity_(gravity), t_(t), opt_(options) {
    // Follower loads have no potential; segments turning about an axis are not among the
    // unknowns here.
    for (const Load& l : rod_.loads())
      if (l.follower)
        throw std::invalid_argument("statics: rod '" + rod_.name() +
                                    "' has a follower load, which has no potential energy");
    if (!rod_.segment_constraints().empty())
      throw std::invalid_argument("statics: rod '" + rod_.name() +
                                  "' has a segment turning about an axis, which statics does "
                                  "not handle");
    for (GhostFrame* g : {&rod_.ghost_start(), &rod_.ghost_end()})
      if (g->active) g->frame = ghost_frame_at(*g, t);
    std::swap(loads_, rod_.loads());
    const int n = rod_.num_segments();
    for (double l : rod_.rest_lengths()) length_ += l;
    lc_ = length_ / n;
    planar_ = options.plane_normal.norm() > 0.0;
    if (planar_) {
      normal_ = options.plane_normal.normalized();
      basis_[0] = normal_.unitOrthogonal();
      basis_[1] = normal_.cross(basis_[0]);
    } else {
      basis_[0] = Vec3::UnitX();
      basis_[1] = Vec3::UnitY();
      basis_[2] = Vec3::UnitZ();
    }
    std::vector<char> node_kin(n + 1, 0), seg_kin(n, 0);
    for (const NodeDrive& d : rod_.node_drives()) node_kin[d.node] = 1;
    for (const SegmentDrive& d : rod_.segment_drives()) seg_kin[d.segment] = 1;
    // Per node its directions of motion (columns, the free ones first) and how many are free.
    node_basis_.assign(n + 1, Mat3::Identity());
    std::vector<int> node_free(n + 1, planar_ ? 2 : 3);
    if (planar_)
      for (Mat3& b : node_basis_) b << basis_[0], basis_[1], normal_;
    anchor_.assign(n + 1, 0);
    for (int i = 0; i <= n; ++i) anchor_[i] = node_kin[i];
    for (const NodeConstraint& c : rod_.node_constraints()) {
      node_free[c.node] = constrained_basis(c, &node_basis_[c.node]);
      anchor_[c.node] = 1;
      constrained_ = true;
      // Onto its line or plane, as the dynamic steps put it.
      Vec3& x = rod_.positions()[c.node];
      const Vec3& a = c.direction;
      x = c.kind == NodeConstraint::Kind::kLine ? Vec3(c.point + a * a.dot(x - c.point))
                                                : Vec3(x - a * a.dot(x - c.point));
    }
    start_.assign(2 * n + 1, 0);
    count_.assign(2 * n + 1, 0);
    for (int p = 0; p <= 2 * n; ++p) {
      const bool node = p % 2 == 0;
      const bool kin = node ? node_kin[p / 2] : seg_kin[p / 2];
      start_[p] = ndof_;
      count_[p] = kin ? 0 : (node ? node_free[p / 2] : (planar_ ? 1 : 3));
      ndof_ += count_[p];
    }
    // Unknown k of item p sits at 6 (p / 2) + 3 (p % 2) + k of the block layout
    // (model/rod_system.h).
    full_.resize(ndof_);
    for (int p = 0; p <= 2 * n; ++p)
      for (int k = 0; k < count_[p]; ++k) full_[start_[p] + k] = 3 * p + k;
    for (auto& v : rod_.velocities()) v.setZero();
    for (auto& w : rod_.angular_velocities()) w.setZero();
  }
  ~Problem() { std::swap(loads_, rod_.loads()); }
  Problem(const Problem&) = delete;
  Problem& operator=(const Problem&) = delete;

  int dofs() const { return ndof_; }
  int evaluations() const { return evaluations_; }
  void set_lambda(double lambda) { lambda_ = lambda; }

  // Minus the energy gradient in scaled unknowns; also the reference force (weights, loads and
  // reactions on kinematic DOFs).
  Eigen::VectorXd residual(double* reference = nullptr) {
    rod_.compute_forces(t_, lambda_ * gravity_);
    ++evaluations_;
    std::vector<Vec3> f = rod_.forces(), tau = rod_.torques();
    double ref2 = 0.0;
    for (int i = 0; i < rod_.num_nodes(); ++i)
      ref2 += (lambda_ * rod_.node_masses()[i] * gravity_).squaredNorm();
    for (const Load& l : loads_) {
      const double k = lambda_ * l.scale(t_);
      if (k == 0.0) continue;
      const Vec3 load = load_world(l, k, rod_.orientations());
      if (l.kind == Load::Kind::kForce) {
        f[l.index] += load;
        ref2 += load.squaredNorm();
      } else {
        tau[l.index] += load_body_torque(l, k, rod_.orientations()[l.index]);
        ref2 += (load / lc_).squaredNorm();
      }
    }
    Eigen::VectorXd r(ndof_);
    for (size_t p = 0; p < start_.size(); ++p) {
      const int i = static_cast<int>(p / 2);
      const bool node = p % 2 == 0;
      if (count_[p] == 0) {  // a reaction
        ref2 += node ? f[i].squaredNorm() : (tau[i] / lc_).squaredNorm();
        continue;
      }
      for (int k = 0; k < count_[p]; ++k)
        r(start_[p] + k) = node ? f[i].dot(node_basis_[i].col(k)) : tau[i].dot(axis(i, k)) / lc_;
      if (node && anchor_[i])  // a sliding node: its support takes the rest
        for (int k = count_[p]; k < 3; ++k) ref2 += std::pow(f[i].dot(node_basis_[i].col(k)), 2);
    }
    tau_ = std::move(tau);
    if (reference) *reference = std::sqrt(ref2);
    return r;
  }

  // Elastic and gravity energy minus the work of the loads from the base state along the
  // current step: exact for dead forces, and for dead torques too because a step turns each
  // segment about a fixed world axis.
  double merit(const Eigen::VectorXd& d, double alpha) {
    const Energies e = rod_.energies(lambda_ * gravity_);
    double work = 0.0;
    for (const Load& l : loads_) {
      const double k = lambda_ * l.scale(t_);
      if (k == 0.0) continue;
      const int p = l.kind == Load::Kind::kForce ? 2 * l.index : 2 * l.index + 1;
      if (count_[p] == 0) continue;
      if (l.kind == Load::Kind::kForce)
        work += load_work(l, k, rod_.positions()[l.index] - x0_[l.index]);
      else
        work += load_work(l, k, q0_[l.index] * (alpha * rotation(l.index, d)));
    }
    return e.elastic() + e.gravity - work;
  }

  // Elastic and gravity energy minus the potential -F.x of the force loads.
  double total_energy() const {
    const Energies e = rod_.energies(lambda_ * gravity_);
    double work = 0.0;
    for (const Load& l : loads_)
      if (load_has_potential(l))
        work += load_work(l, lambda_ * l.scale(t_), rod_.positions()[l.index]);
    return e.elastic() + e.gravity - work;
  }

  // Energy scale for telling a real decrease from round-off.
  double energy_noise() const {
    const Energies e = rod_.energies(lambda_ * gravity_);
    return 1e3 * kEps * (std::abs(e.elastic()) + std::abs(e.gravity) + 1e-300);
  }

  // Residual noise of the force computation: strains carry round-off of eps (1 + |x|/l).
  double round_off_floor() const {
    const Section& s = rod_.section();
    double xmax = 0.0;
    for (const Vec3& x : rod_.positions()) xmax = std::max(xmax, x.cwiseAbs().maxCoeff());
    return kEps * std::sqrt(static_cast<double>(ndof_) + 1.0) * (1.0 + xmax / lc_) *
           (s.stretch + s.kappa + (s.bend + s.twist) / (lc_ * lc_));
  }

  void save_base() {
    x0_ = rod_.positions();
    q0_ = rod_.orientations();
  }
  void restore_base() {
    rod_.positions() = x0_;
    rod_.orientations() = q0_;
  }

  // State = base + alpha d: rotations composed in the body frame; positions added (linear) or,
  // for steps, through a retraction that turns each chord exactly by the rotation its linear
  // change describes and changes its length linearly. Both agree to first order, but with a
  // stiff stretch the linear update strains every chord it turns by theta^2/2, which stalls
  // Newton; the retraction does not. Chains are rebuilt from the kinematic nodes (or node 0),
  // and the O(d^2) misclosure between two kinematic nodes is spread linearly along the chain.
  void move(const Eigen::VectorXd& d, double alpha, bool linear = false) {
    std::vector<Vec3>& x = rod_.positions();
    const int nn = rod_.num_nodes();
    for (size_t p = 0; p < start_.size(); ++p) {
      if (count_[p] == 0) continue;
      const int i = static_cast<int>(p / 2);
      if (p % 2 == 0) {
        Vec3 dx = Vec3::Zero();
        for (int k = 0; k < count_[p]; ++k) dx += d(start_[p] + k) * node_basis_[i].col(k);
        x[i] = x0_[i] + alpha * dx;
      } else {
        rod_.orientations()[i] = (q0_[i] * so3::exp_exact(alpha * rotation(i, d))).normalized();
      }
    }
    if (linear) return;
    chords_.resize(nn - 1);
    for (int s = 0; s + 1 < nn; ++s) {
      const Vec3 e = x0_[s + 1] - x0_[s];
      const Vec3 de = (x[s + 1] - x0_[s + 1]) - (x[s] - x0_[s]);
      const double len = e.norm();
      const Vec3 t = e / len;
      const double dpar = t.dot(de);
      const Vec3 phi = t.cross(de - dpar * t) / len;
      chords_[s] = ((len + dpar) / len) * (so3::exp_exact(phi) * e);
    }
    int a = -1;  // last anchor
    for (int i = 0; i < nn; ++i) {
      if (!anchor_[i]) continue;
      if (a < 0) {
        for (int j = i - 1; j >= 0; --j) x[j] = x[j + 1] - chords_[j];
      } else {
        Vec3 y = x[a];
        for (int j = a + 1; j < i; ++j) x[j] = (y += chords_[j - 1]);
        const Vec3 miss = y + chords_[i - 1] - x[i];
        for (int j = a + 1; j < i; ++j) x[j] -= (static_cast<double>(j - a) / (i - a)) * miss;
      }
      a = i;
    }
    if (a < 0) a = 0;  // a free rod: built from node 0
    for (int j = a + 1; j < nn; ++j) x[j] = x[j - 1] + chords_[j - 1];
    if (planar_)  // keep round-off of the rotations from leaving the plane
      for (int j = 0; j < nn; ++j) x[j] -= normal_ * normal_.dot(x[j] - x0_[j]);
  }

  // Whether dead torque loads act at this load factor (forces without a potential on rotations).
  bool has_dead_torques() const {
    for (const Load& l : loads_)
      if (l.kind == Load::Kind::kTorque && lambda_ * l.scale(t_) != 0.0) return true;
    return false;
  }

  // Scales d down so that no node moves more than max_step rod lengths and no segment turns more
  // than max_step radians; returns the factor applied.
  double cap(Eigen::VectorXd* d) {
    double worst = 1.0;
    for (size_t p = 0; p < start_.size(); ++p) {
      if (count_[p] == 0) continue;
      const double m = d->segment(start_[p], count_[p]).norm();
      const double limit = opt_.max_step * (p % 2 == 0 ? length_ : lc_);
      worst = std::max(worst, m / limit);
    }
    *d /= worst;
    return 1.0 / worst;
  }

  // Adds to the Hessian from system_matrix() (same layout and unknowns) the skew parts that make
  // it the Jacobian of minus the residual along the retraction: per free segment
  // -[tau / 2 + m]x / lc^2 in its rotation block (body frame, in its basis), tau the body torque
  // of all forces at the current state and m that of the dead torque loads. The first is the
  // retraction's ((1/2) [g]x, g the body gradient, model/rod_system.h); the second the turning of
  // the dead torques against the body, which no potential's Hessian holds: with large rotations
  // it can leave the symmetric part indefinite at an equilibrium that dynamics reaches. Zero in
  // the planar case.
  void add_torque_jacobian(BlockTridiag* a) {
    residual();
    std::vector<Vec3> w = tau_;
    for (Vec3& v : w) v *= 0.5;
    for (const Load& l : loads_) {
      const double k = lambda_ * l.scale(t_);
      if (k == 0.0 || l.kind != Load::Kind::kTorque) continue;
      w[l.index] += load_body_torque(l, k, rod_.orientations()[l.index]);
    }
    const int ns = rod_.num_segments();
    Mat6 t;
    for (int s = 0; s < ns; ++s) {
      const int p = 2 * s + 1;
      if (count_[p] == 0) continue;
      basis_block(s, &t);
      const Mat3 tb = t.bottomRightCorner<3, 3>();
      a->diag[s].bottomRightCorner<3, 3>() -= tb.transpose() * so3::skew(w[s]) * tb;
      for (int k = count_[p]; k < 3; ++k) a->fix(3 * p + k);
    }
  }

  // The Hessian in the block layout of model/rod_system.h, in the scaled unknowns: each item's 3x3
  // blocks turned into its basis (the plane's, or the rotation axis first) and scaled by 1/lc
  // for the rotations, the components that are not unknowns fixed. Analytic, or from
  // hessian() (central differences) when asked.
  void system_matrix(BlockTridiag* a) {
    const int nb = rod_.num_nodes();
    if (opt_.finite_difference_hessian) {
      const Eigen::SparseMatrix<double> h = hessian();
      a->resize(nb);
      a->set_zero();
      for (int c = 0; c < h.outerSize(); ++c)
        for (Eigen::SparseMatrix<double>::InnerIterator it(h, c); it; ++it) {
          const int i = full_[it.row()], j = full_[it.col()];
          if (i / 6 == j / 6)
            a->diag[i / 6](i % 6, j % 6) = it.value();
          else if (i / 6 == j / 6 + 1)
            a->lower[j / 6](i % 6, j % 6) = it.value();
        }
    } else {
      RodSystem sys{&rod_, lambda_ * gravity_, t_, lambda_,
                    kStretchTerm | kCouplingTerm | kBendTwistTerm};
      sys.hessian(a);  // loads and gravity add nothing to it
      std::vector<Mat6>& d = a->diag;
      std::vector<Mat6>& l = a->lower;
      int nb_done = 0;
      Mat6 tk, tn;
      if (!planar_ && !constrained_) {  // the map is a diagonal scaling
        Vec6 sc;
        sc << 1.0, 1.0, 1.0, 1.0 / lc_, 1.0 / lc_, 1.0 / lc_;
        for (Mat6& m : d) m = sc.asDiagonal() * m * sc.asDiagonal();
        for (Mat6& m : l) m = sc.asDiagonal() * m * sc.asDiagonal();
        nb_done = nb;
      }
      if (nb_done == 0) basis_block(0, &tk);
      for (int k = nb_done; k < nb; ++k) {
        d[k] = tk.transpose() * d[k] * tk;
        if (k + 1 < nb) {
          basis_block(k + 1, &tn);
          l[k] = tn.transpose() * l[k] * tk;
          tk = tn;
        }
      }
    }
    for (int p = 0; p < 2 * nb; ++p)
      for (int k = p < static_cast<int>(count_.size()) ? count_[p] : 0; k < 3; ++k)
        a->fix(3 * p + k);
  }

  // Scatters the residual into the block layout (zero on fixed slots) and back.
  void to_blocks(const Eigen::VectorXd& r, Eigen::VectorXd* b) const {
    b->setZero(6 * rod_.num_nodes());
    for (int i = 0; i < ndof_; ++i) (*b)(full_[i]) = r(i);
  }
  void from_blocks(const Eigen::VectorXd& b, Eigen::VectorXd* r) const {
    r->resize(ndof_);
    for (int i = 0; i < ndof_; ++i) (*r)(i) = b(full_[i]);
  }
  int block_index(int i) const { return full_[i]; }

  // dy/dp = -A^-1 T^T dg/dp for each rate (A the system matrix, T the map from the scaled unknowns
  // to displacements and body rotations, basis_block), mapped back by T. dg/dp: the gradient of
  // the elastic and gravity terms with the rates in place of the section constants and of the
  // nodes' section masses.
  std::vector<StaticSensitivity> sensitivity(const std::vector<SectionRate>& rates) {
    const int nb = rod_.num_nodes();
    BlockTridiag a;
    system_matrix(&a);
    const bool torques = has_dead_torques();
    if (torques) add_torque_jacobian(&a);
    double diag = 0.0;
    for (int i = 0; i < ndof_; ++i)
      diag = std::max(diag, std::abs(a.diag[full_[i] / 6](full_[i] % 6, full_[i] % 6)));
    BlockTridiagSolver chol;
    BlockTridiagLU lu;
    const bool use_chol = !torques && chol.factor(a, 1e-13 * diag);
    if (!use_chol && !lu.factor(a))
      throw std::runtime_error("statics sensitivity: rod '" + rod_.name() +
                               "': the equilibrium's Hessian is singular (a free rigid motion or "
                               "a neutral direction): the equilibrium does not depend on the "
                               "material uniquely");
    const Section& sec = rod_.section();
    std::vector<double> masses(nb, 0.0);
    std::vector<StaticSensitivity> out;
    Eigen::VectorXd g, b(6 * nb);
    std::vector<Mat6> t(nb);
    for (int k = 0; k < nb; ++k) basis_block(k, &t[k]);
    for (const SectionRate& rate : rates) {
      Section ds = sec;
      ds.bend = rate.bend;
      ds.twist = rate.twist;
      ds.stretch = rate.stretch;
      ds.kappa = rate.kappa;
      const double mscale =
          sec.mass_per_length > 0.0 ? rate.mass_per_length / sec.mass_per_length : 0.0;
      const std::vector<double>& added = rod_.added_node_masses();
      for (int i = 0; i < nb; ++i)
        masses[i] = mscale * (rod_.node_masses()[i] - (added.empty() ? 0.0 : added[i]));
      RodSystem sys{&rod_, gravity_, t_, 1.0,
                    kStretchTerm | kCouplingTerm | kBendTwistTerm | kGravityTerm};
      sys.section = &ds;
      sys.node_masses = &masses;
      sys.gradient(&g);
      for (int k = 0; k < nb; ++k) b.segment<6>(6 * k) = -(t[k].transpose() * g.segment<6>(6 * k));
      Eigen::VectorXd r;
      from_blocks(b, &r);
      to_blocks(r, &b);  // zero on the held and unused slots
      if (use_chol)
        chol.solve(&b);
      else
        lu.solve(&b);
      StaticSensitivity sv;
      sv.positions.assign(nb, Vec3::Zero());
      sv.rotations.assign(rod_.num_segments(), Vec3::Zero());
      for (int k = 0; k < nb; ++k) {
        const Vec6 d = t[k] * b.segment<6>(6 * k);
        sv.positions[k] = d.head<3>();
        if (k < rod_.num_segments()) sv.rotations[k] = d.tail<3>();
      }
      out.push_back(std::move(sv));
    }
    return out;
  }

  // Symmetrised central-difference Jacobian of minus the residual, by colours. Second order
  // (30 force evaluations) for Newton; fourth order (60) where the Hessian itself is the result:
  // with a stiff stretch or penalty the second-order stencil's truncation error, K_s h^2 / l^3,
  // is not small against the geometric stiffness of soft modes (P / l).
  Eigen::SparseMatrix<double> hessian(bool fourth_order = false) {
    save_base();
    const double h = 1e-4 * lc_;
    std::vector<Eigen::Triplet<double>> trip;
    trip.reserve(static_cast<size_t>(ndof_) * 16 * 3);
    const int blocks = static_cast<int>(start_.size());
    Eigen::VectorXd d(ndof_), diff(ndof_);
    for (int c = 0; c < kColours; ++c) {
      for (int k = 0; k < 3; ++k) {
        d.setZero();
        bool any = false;
        for (int p = c; p < blocks; p += kColours)
          if (count_[p] > k) {
            d(start_[p] + k) = h;
            any = true;
          }
        if (!any) continue;
        // diff = -(dr/dy) d / h, the colour's columns summed.
        auto central = [&](double s) {
          move(d, s, true);
          const Eigen::VectorXd rp = residual();
          move(d, -s, true);
          return Eigen::VectorXd((residual() - rp) / (2.0 * s * h));
        };
        diff = central(1.0);
        if (fourth_order) diff = (4.0 * diff - central(2.0)) / 3.0;
        for (int p = c; p < blocks; p += kColours) {
          if (count_[p] <= k) continue;
          const int col = start_[p] + k;
          for (int b = std::max(0, p - kReach); b <= std::min(blocks - 1, p + kReach); ++b)
            for (int j = 0; j < count_[b]; ++j)
              trip.emplace_back(start_[b] + j, col, diff(start_[b] + j));
        }
      }
    }
    restore_base();
    Eigen::SparseMatrix<double> a(ndof_, ndof_);
    a.setFromTriplets(trip.begin(), trip.end());
    Eigen::SparseMatrix<double> at = a.transpose();
    return 0.5 * (a + at);
  }

  // Drive state at t (kinematic DOFs) and continuation between two such states.
  void drive_targets(std::vector<Vec3>* x, std::vector<Quat>* q) const {
    *x = rod_.positions();
    *q = rod_.orientations();
    for (const NodeDrive& d : rod_.node_drives()) (*x)[d.node] = drive_position(d, t_);
    for (const SegmentDrive& d : rod_.segment_drives())
      (*q)[d.segment] = drive_orientation_near(d, t_, (*q)[d.segment]);
  }

  // Puts kinematic DOFs at fraction `lambda` from (xs, qs) to (xt, qt) and moves the free nodes by
  // the kinematic nodes' displacement interpolated along the rod (a predictor).
  void place_kinematic(const std::vector<Vec3>& xs, const std::vector<Quat>& qs,
                       const std::vector<Vec3>& xt, const std::vector<Quat>& qt, double lambda) {
    const int nn = rod_.num_nodes();
    std::vector<int> kin;
    std::vector<Vec3> disp;
    for (int i = 0; i < nn; ++i)
      if (count_[2 * i] == 0) {
        kin.push_back(i);
        disp.push_back(xs[i] + lambda * (xt[i] - xs[i]) - rod_.positions()[i]);
      }
    if (!kin.empty()) {
      size_t k = 0;
      for (int i = 0; i < nn; ++i) {
        while (k + 1 < kin.size() && kin[k + 1] <= i) ++k;
        Vec3 dx = disp[k];
        if (i > kin[k] && k + 1 < kin.size()) {
          const double w = static_cast<double>(i - kin[k]) / (kin[k + 1] - kin[k]);
          dx = (1.0 - w) * disp[k] + w * disp[k + 1];
        } else if (i < kin[k]) {
          dx = disp[0];
        }
        rod_.positions()[i] += dx;
      }
    }
    for (int s = 0; s < rod_.num_segments(); ++s)
      if (count_[2 * s + 1] == 0) rod_.orientations()[s] = qs[s].slerp(lambda, qt[s]).normalized();
    // Keyframed drives and moving clamps follow their motion from time 0 to t through the load
    // steps instead: a straight slerp would lose every whole turn of a twisted end.
    for (const NodeDrive& d : rod_.node_drives())
      if (d.kind == NodeDrive::Kind::kMotion)
        rod_.positions()[d.node] = drive_position(d, lambda * t_);
    for (const SegmentDrive& d : rod_.segment_drives())
      if (d.kind == SegmentDrive::Kind::kMotion)
        rod_.orientations()[d.segment] = drive_orientation(d, lambda * t_);
    for (GhostFrame* g : {&rod_.ghost_start(), &rod_.ghost_end()})
      if (g->active && g->motion) g->frame = ghost_frame_at(*g, lambda * t_);
  }

 private:
  // The 6x6 map from the scaled unknowns of block k (node k, segment k) to its displacement and
  // body rotation: the node's basis vectors as columns, and the segment's rotation axes (in the
  // planar case the plane's normal in the body first) over lc.
  void basis_block(int k, Mat6* t) const {
    t->setZero();
    if (!planar_ && !constrained_) {
      t->diagonal() << 1.0, 1.0, 1.0, 1.0 / lc_, 1.0 / lc_, 1.0 / lc_;
      return;
    }
    t->topLeftCorner<3, 3>() = node_basis_[k];
    if (!planar_) {
      if (k < rod_.num_segments()) t->bottomRightCorner<3, 3>().diagonal().setConstant(1.0 / lc_);
      return;
    }
    if (k >= rod_.num_segments()) {
      t->bottomRightCorner<3, 3>().setIdentity();
      return;
    }
    const Vec3 a = axis(k, 0);
    const Vec3 b = a.unitOrthogonal();
    t->block<3, 1>(3, 3) = a / lc_;
    t->block<3, 1>(3, 4) = b / lc_;
    t->block<3, 1>(3, 5) = a.cross(b) / lc_;
  }

  // Directions of motion of a node on a line or a plane (columns of b, orthonormal, the free ones
  // first), within the plane of a planar problem; returns how many are free.
  int constrained_basis(const NodeConstraint& c, Mat3* b) const {
    const Vec3& a = c.direction;
    const bool line = c.kind == NodeConstraint::Kind::kLine;
    constexpr double kParallel = 1e-9;
    if (!planar_) {
      const Vec3 u = a.unitOrthogonal();
      if (line) {
        *b << a, u, a.cross(u);
        return 1;
      }
      *b << u, a.cross(u), a;
      return 2;
    }
    const Vec3& n = normal_;
    if (line) {  // free along the line if it lies in the plane
      if (std::abs(a.dot(n)) > kParallel) return 0;
      *b << a, n.cross(a), n;
      return 1;
    }
    if (n.cross(a).norm() <= kParallel) {  // the same plane
      *b << basis_[0], basis_[1], n;
      return 2;
    }
    const Vec3 u = n.cross(a).normalized();  // the planes' common line
    *b << u, n, u.cross(n);
    return 1;
  }

  // Body axis of rotation unknown k of segment s.
  Vec3 axis(int s, int k) const {
    if (!planar_) return Vec3::Unit(k);
    return rod_.orientations()[s].conjugate() * normal_;
  }
  // Body rotation vector (rad) of segment s in the step d, about the base orientation.
  Vec3 rotation(int s, const Eigen::VectorXd& d) const {
    const int p = 2 * s + 1;
    if (count_[p] == 0) return Vec3::Zero();
    if (planar_) return (d(start_[p]) / lc_) * (q0_[s].conjugate() * normal_);
    return d.segment<3>(start_[p]) / lc_;
  }

  Rod& rod_;
  Vec3 gravity_;
  double t_;
  StaticOptions opt_;
  std::vector<Load> loads_;
  double lambda_ = 1.0, length_ = 0.0, lc_ = 1.0;
  bool planar_ = false, constrained_ = false;
  Vec3 normal_ = Vec3::Zero();
  Vec3 basis_[3];
  std::vector<Mat3> node_basis_;  // per node: its directions of motion, the free ones first
  std::vector<char> anchor_;      // per node: held or sliding (the retraction builds from them)
  std::vector<Vec3> tau_;         // body torques of the last residual(), loads included
  std::vector<int> start_, count_, full_;
  int ndof_ = 0, evaluations_ = 0;
  std::vector<Vec3> x0_, chords_;
  std::vector<Quat> q0_;
};

// Newton iterations at one load factor on the shared solver (linalg/newton.h). Each iteration
// tries, until a line search accepts: the Hessian with the last iteration's Levenberg shift (a
// tenth of it; none at first), with a line search on the energy; then, where that fails without a
// shift and dead torques act, the full Jacobian of the residual (add_torque_jacobian, by block LU)
// with a line search on |r|^2 / 2: Newton's method proper where dead torques turn the rod far (the
// symmetric part alone turns indefinite there and shifted steps crawl); then growing shifts (x10)
// up to the largest diagonal entry.
class StaticsNewton : public NewtonProblem {
 public:
  StaticsNewton(Problem* pb, double tol, StaticResult* res)
      : pb_(*pb), tol_(tol), res_(*res), floor_(pb->round_off_floor()) {
    r_ = pb_.residual(&ref_);
  }

  bool run(int max_iterations) {
    if (pb_.dofs() == 0) return finish(true);
    NewtonOptions o;
    o.max_iterations = max_iterations;
    o.keep_merit = false;  // the energy's work term is measured from each iterate
    o.line_search.max_trials = 40;
    o.line_search.require_descent = true;
    o.line_search.armijo_on_change = true;
    const NewtonOutcome out = newton_solve(this, o);
    res_.iterations += out.iterations;
    return finish(out.stop == NewtonStop::kStopped);
  }

  double residual_norm() override { return r_.norm(); }

  Check check(double norm) override {
    if (norm <= tol_ * ref_) return Check::kConverged;
    // At the noise floor, stop once an iteration no longer halves the residual.
    if (norm <= floor_ && norm > 0.5 * last_norm_) return Check::kStop;
    last_norm_ = norm;
    return Check::kContinue;
  }

  bool direction(int attempt, double* slope) override {
    if (attempt == 0) {
      pb_.system_matrix(&h_);
      diag_ = 0.0;
      for (int i = 0; i < pb_.dofs(); ++i) {
        const int j = pb_.block_index(i);
        diag_ = std::max(diag_, std::abs(h_.diag[j / 6](j % 6, j % 6)));
      }
      mu_ = mu_last_ > 1e-12 * diag_ ? 0.1 * mu_last_ : 0.0;
      full_next_ = full_tried_ = false;
    }
    for (;;) {
      if (full_next_) {
        full_next_ = false;
        a_ = h_;
        pb_.add_torque_jacobian(&a_);
        if (lu_.factor(a_)) {
          solve(&lu_);
          const double scale = pb_.cap(&d_);
          full_ = true;
          pb_.save_base();
          phi0_ = 0.5 * r_.squaredNorm();
          *slope = -scale * r_.squaredNorm();
          return true;
        }
      }
      if (mu_ > diag_) return false;
      a_ = h_;
      for (int i = 0; i < pb_.dofs() && mu_ > 0.0; ++i) {
        const int j = pb_.block_index(i);
        a_.diag[j / 6](j % 6, j % 6) += mu_;
      }
      if (chol_.factor(a_, 1e-13 * diag_)) {
        solve(&chol_);
        pb_.cap(&d_);
        full_ = false;
        pb_.save_base();
        phi0_ = pb_.merit(d_, 0.0);
        noise0_ = pb_.energy_noise();
        *slope = -r_.dot(d_);  // d merit / d alpha at 0
        return true;
      }
      escalate();
    }
  }

  Retry rejected(int attempt) override {
    (void)attempt;
    pb_.restore_base();
    if (!full_) escalate();
    if (mu_ > diag_ && !full_next_) {
      if (mu_ > 0.0) ++res_.shifted_iterations;
      return Retry::kStop;
    }
    return Retry::kSameIteration;
  }

  void accepted(int attempt) override {
    (void)attempt;
    const double mu = full_ ? 0.0 : mu_;
    if (mu > 0.0) ++res_.shifted_iterations;
    mu_last_ = mu;
  }

  void move(double alpha) override {
    pb_.move(d_, alpha);
    have_trial_ = false;
  }
  double merit(double alpha) override {
    if (!full_) return pb_.merit(d_, alpha);
    trial_residual();
    return 0.5 * trial_.squaredNorm();
  }
  void base_merit(MeritAtIterate* m) override {
    m->phi = phi0_;
    m->noise = full_ ? 0.0 : noise0_;
  }
  double trial_residual() override {
    if (!have_trial_) trial_ = pb_.residual(&ref_trial_);
    have_trial_ = true;
    return trial_.norm();
  }
  void accept_trial() override {
    r_.swap(trial_);
    ref_ = ref_trial_;
    have_trial_ = false;
  }

 private:
  // d = A^-1 r in the unknowns (H d = -grad = r).
  template <class Solver>
  void solve(Solver* s) {
    pb_.to_blocks(r_, &b_);
    s->solve(&b_);
    pb_.from_blocks(b_, &d_);
  }
  // After a failed factorisation or search on the Hessian: the full Jacobian once, where no
  // shift was needed yet; else a larger shift.
  void escalate() {
    if (!full_tried_ && mu_ == 0.0 && pb_.has_dead_torques()) {
      full_tried_ = full_next_ = true;
      return;
    }
    mu_ = mu_ > 0.0 ? 10.0 * mu_ : 1e-10 * diag_;
  }
  bool finish(bool stalled) {
    res_.residual = r_.norm();
    res_.reference_force = ref_;
    res_.relative_residual = ref_ > 0.0 ? res_.residual / ref_ : res_.residual;
    res_.round_off_floor = floor_;
    return res_.residual <= tol_ * ref_ || (stalled && res_.residual <= floor_);
  }

  Problem& pb_;
  double tol_;
  StaticResult& res_;
  double floor_;
  Eigen::VectorXd r_, trial_, b_, d_;
  double ref_ = 0.0, ref_trial_ = 0.0, phi0_ = 0.0, noise0_ = 0.0;
  bool have_trial_ = false;
  double last_norm_ = std::numeric_limits<double>::infinity();
  BlockTridiag h_, a_;
  BlockTridiagSolver chol_;
  BlockTridiagLU lu_;
  double diag_ = 0.0, mu_ = 0.0;
  bool full_ = false, full_next_ = false, full_tried_ = false;
  double mu_last_ = 0.0;  // the last iteration's shift (within this load step)
};

bool newton(Problem* pb, double tol, const StaticOptions& opt, StaticResult* res) {
  StaticsNewton solver(pb, tol, res);
  return solver.run(opt.max_iterations);
}

}  // namespace

StaticResult solve_statics(Rod& rod, const Vec3& gravity, double t, const StaticOptions& options) {
  StaticResult res;
  Problem pb(rod, gravity, t, options);
  res.unknowns = pb.dofs();
  std::vector<Vec3> xs = rod.positions(), xt;
  std::vector<Quat> qs = rod.orientations(), qt;
  pb.drive_targets(&xt, &qt);
  const int steps = std::max(1, options.load_steps);
  for (int k = 1; k <= steps; ++k) {
    const double lambda = static_cast<double>(k) / steps;
    pb.set_lambda(lambda);
    pb.place_kinematic(xs, qs, xt, qt, lambda);
    const bool last = k == steps;
    const bool ok =
        newton(&pb, last ? options.tolerance : std::sqrt(options.tolerance), options, &res);
    res.load_steps = k;
    res.converged = ok;
    if (!ok && last) break;
    if (!rod.finite()) {
      res.converged = false;
      break;
    }
  }
  pb.set_lambda(1.0);
  res.energy = pb.total_energy();
  res.gradient_evaluations = pb.evaluations();
  return res;
}

Eigen::SparseMatrix<double> static_hessian(Rod& rod, const Vec3& gravity, double t,
                                           const StaticOptions& options) {
  Problem pb(rod, gravity, t, options);
  if (options.finite_difference_hessian) return pb.hessian(true);
  BlockTridiag a;
  pb.system_matrix(&a);
  const int n = pb.dofs();
  std::vector<int> reduced(a.size(), -1);
  for (int i = 0; i < n; ++i) reduced[pb.block_index(i)] = i;
  std::vector<Eigen::Triplet<double>> trip;
  const Eigen::SparseMatrix<double> full = to_sparse(a);
  for (int c = 0; c < full.outerSize(); ++c)
    for (Eigen::SparseMatrix<double>::InnerIterator it(full, c); it; ++it) {
      const int i = reduced[it.row()], j = reduced[it.col()];
      if (i >= 0 && j >= 0) trip.emplace_back(i, j, it.value());
    }
  Eigen::SparseMatrix<double> h(n, n);
  h.setFromTriplets(trip.begin(), trip.end());
  return h;
}

std::vector<StaticSensitivity> static_sensitivity(Rod& rod, const Vec3& gravity, double t,
                                                  const std::vector<SectionRate>& rates,
                                                  const StaticOptions& options) {
  Problem pb(rod, gravity, t, options);
  return pb.sensitivity(rates);
}

}  // namespace corde
