#include "corde_sim/model/rod_system.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

namespace corde {

namespace {

Mat3 skew(const Vec3& v) {
  Mat3 m;
  m << 0.0, -v.z(), v.y(), v.z(), 0.0, -v.x(), -v.y(), v.x(), 0.0;
  return m;
}

// What one bending-twist element needs: sigma, r = conj(a) (x) b = (w, v), and e = dV/du.
struct BendParts {
  double sigma, w;
  Vec3 v, e;
};

BendParts bend_parts(const Quat& a, const Quat& b, double rest, const Vec3& k, const Vec3& uhat) {
  BendParts p;
  p.w = a.coeffs().dot(b.coeffs());
  p.sigma = p.w < 0.0 ? -1.0 : 1.0;
  p.v = rel_vec(a, b);
  const Vec3 u = (2.0 * p.sigma / rest) * p.v;
  p.e = rest * k.cwiseProduct(u - uhat);
  return p;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// BlockTridiag

void BlockTridiag::resize(int blocks) {
  diag.resize(blocks);
  lower.resize(std::max(0, blocks - 1));
}

void BlockTridiag::set_zero() {
  for (Mat6& m : diag) m.setZero();
  for (Mat6& m : lower) m.setZero();
}

void BlockTridiag::add(int r, int c, const Mat3& m) {
  const int br = r / 6, bc = c / 6, ro = r % 6, co = c % 6;
  if (br == bc) {
    diag[br].block<3, 3>(ro, co) += m;
    if (r != c) diag[br].block<3, 3>(co, ro) += m.transpose();
  } else if (br == bc + 1) {
    lower[bc].block<3, 3>(ro, co) += m;
  } else {
    lower[br].block<3, 3>(co, ro) += m.transpose();
  }
}

void BlockTridiag::fix(int i) {
  const int k = i / 6, o = i % 6;
  diag[k].row(o).setZero();
  diag[k].col(o).setZero();
  diag[k](o, o) = 1.0;
  if (k < static_cast<int>(lower.size())) lower[k].col(o).setZero();
  if (k > 0) lower[k - 1].row(o).setZero();
}

void BlockTridiag::multiply(const Eigen::VectorXd& x, Eigen::VectorXd* y) const {
  y->resize(size());
  const int n = blocks();
  for (int k = 0; k < n; ++k) {
    Vec6 acc = diag[k] * x.segment<6>(6 * k);
    if (k > 0) acc += lower[k - 1] * x.segment<6>(6 * k - 6);
    if (k + 1 < n) acc += lower[k].transpose() * x.segment<6>(6 * k + 6);
    y->segment<6>(6 * k) = acc;
  }
}

Eigen::MatrixXd BlockTridiag::dense() const {
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(size(), size());
  for (int k = 0; k < blocks(); ++k) {
    a.block<6, 6>(6 * k, 6 * k) = diag[k];
    if (k + 1 < blocks()) {
      a.block<6, 6>(6 * k + 6, 6 * k) = lower[k];
      a.block<6, 6>(6 * k, 6 * k + 6) = lower[k].transpose();
    }
  }
  return a;
}

Eigen::SparseMatrix<double> BlockTridiag::sparse() const {
  std::vector<Eigen::Triplet<double>> trip;
  trip.reserve(static_cast<size_t>(blocks()) * 36 * 3);
  for (int k = 0; k < blocks(); ++k)
    for (int i = 0; i < 6; ++i)
      for (int j = 0; j < 6; ++j) {
        if (diag[k](i, j) != 0.0) trip.emplace_back(6 * k + i, 6 * k + j, diag[k](i, j));
        if (k + 1 < blocks() && lower[k](i, j) != 0.0) {
          trip.emplace_back(6 * k + 6 + i, 6 * k + j, lower[k](i, j));
          trip.emplace_back(6 * k + j, 6 * k + 6 + i, lower[k](i, j));
        }
      }
  Eigen::SparseMatrix<double> a(size(), size());
  a.setFromTriplets(trip.begin(), trip.end());
  return a;
}

// ---------------------------------------------------------------------------------------------
// BlockTridiagSolver: S_0 = A_00, S_k = A_kk - C_{k-1} C_{k-1}^T with L_kk = chol(S_k) and
// C_k = A_{k+1,k} L_kk^-T.

namespace {

// Cholesky of the 6x6 s (lower triangle read) into l (lower triangle written; the strict upper
// triangle gets finite values of no meaning) and the inverse of its diagonal; false when a pivot
// l_jj^2 is <= min_pivot (or NaN). Left-looking, a whole column at a time: column operations
// vectorise where element-wise loops would not.
bool cholesky6(const Mat6& s, double min_pivot, Mat6* l, Vec6* inv_diag) {
  for (int j = 0; j < 6; ++j) {
    Vec6 col = s.col(j);
    for (int k = 0; k < j; ++k) col -= (*l)(j, k) * l->col(k);
    if (!(col(j) > min_pivot)) return false;
    const double inv = 1.0 / std::sqrt(col(j));
    (*inv_diag)(j) = inv;
    l->col(j) = inv * col;
  }
  return true;
}

// x = b L^-T for the factor l of cholesky6 (column j of x solves x L^T = b for that column by
// substitution), accumulated a whole column at a time for the same reason.
void right_solve_lt(const Mat6& l, const Vec6& inv_diag, const Mat6& b, Mat6* x) {
  for (int j = 0; j < 6; ++j) {
    Vec6 col = b.col(j);
    for (int m = 0; m < j; ++m) col -= l(j, m) * x->col(m);
    x->col(j) = inv_diag(j) * col;
  }
}

}  // namespace

bool BlockTridiagSolver::factor(const BlockTridiag& a, double min_pivot) {
  const int n = a.blocks();
  if (static_cast<int>(l_inv_t_.size()) < n) {
    l_inv_t_.resize(n);
    l_lower_.resize(n);
  }
  Mat6 s, l;
  Vec6 inv;
  for (int k = 0; k < n; ++k) {
    s = a.diag[k];
    if (k > 0) {
      // S -= C C^T on the lower triangle only (all cholesky6 reads), in column pairs: a third
      // fewer products than the full block.
      const Mat6& c = l_lower_[k - 1];
      s.block<6, 2>(0, 0).noalias() -= c * c.topRows<2>().transpose();
      s.block<4, 2>(2, 2).noalias() -= c.middleRows<4>(2) * c.middleRows<2>(2).transpose();
      s.block<2, 2>(4, 4).noalias() -= c.bottomRows<2>() * c.bottomRows<2>().transpose();
    }
    if (!cholesky6(s, min_pivot, &l, &inv)) return false;
    // Keeps L^-T (column j of it is row j of L^-1) so that the solves multiply by it, which
    // vectorises, instead of substituting element by element; and C = A_{k+1,k} L^-T.
    right_solve_lt(l, inv, Mat6::Identity(), &l_inv_t_[k]);
    if (k + 1 < n) right_solve_lt(l, inv, a.lower[k], &l_lower_[k]);
  }
  blocks_ = n;
  return true;
}

void BlockTridiagSolver::solve(Eigen::VectorXd* b) const {
  const int n = blocks_;
  Vec6 y;
  for (int k = 0; k < n; ++k) {
    y = b->segment<6>(6 * k);
    if (k > 0) y.noalias() -= l_lower_[k - 1] * b->segment<6>(6 * k - 6);
    b->segment<6>(6 * k).noalias() = l_inv_t_[k].transpose() * y;
  }
  for (int k = n - 1; k >= 0; --k) {
    y = b->segment<6>(6 * k);
    if (k + 1 < n) y.noalias() -= l_lower_[k].transpose() * b->segment<6>(6 * k + 6);
    b->segment<6>(6 * k).noalias() = l_inv_t_[k] * y;
  }
}

// ---------------------------------------------------------------------------------------------
// Term Hessians

Mat3 stretch_hessian(const Vec3& d, double rest, double ks, bool definite) {
  // V = (1/2) l K (|d|/l - 1)^2: axial stiffness K/l along t, and the tension's geometric
  // stiffness K (|d|/l - 1)/|d| across it (negative under compression).
  const double len = d.norm();
  const Vec3 t = d / len;
  const Mat3 tt = t * t.transpose();
  const double strain = definite ? std::max(0.0, len / rest - 1.0) : len / rest - 1.0;
  return (ks / rest) * tt + (ks * strain / len) * (Mat3::Identity() - tt);
}

void coupling_hessian(const Vec3& d, const Quat& q, double rest, double kappa, Mat3* hdd, Mat3* hdt,
                      Mat3* htt, bool definite) {
  // E = c (1 - t . d3) with c = l kappa, t = d/|d|, d3 = R e_z; a body rotation theta moves d3 by
  // -[d3]x R theta to first order.
  const double c = rest * kappa, len = d.norm();
  const Vec3 t = d / len;
  const Mat3 r = q.toRotationMatrix();
  const Vec3 d3 = r.col(2);
  const double td = t.dot(d3);
  const Mat3 tt = t * t.transpose();
  if (hdd) {
    if (definite)  // Gauss-Newton: c (P/|d|)^T (P/|d|)
      *hdd = (c / (len * len)) * (Mat3::Identity() - tt);
    else
      *hdd = (c / (len * len)) *
             (d3 * t.transpose() + t * d3.transpose() + td * (Mat3::Identity() - 3.0 * tt));
  }
  if (hdt) {
    // (c/|d|) P [d3]x R with P = I - t t^T; [d3]x R = (d3 x d1, d3 x d2, 0) = (d2, -d1, 0).
    const Vec3 d1 = r.col(0), d2 = r.col(1);
    hdt->col(0) = (c / len) * (d2 - t.dot(d2) * t);
    hdt->col(1) = (c / len) * (t.dot(d1) * t - d1);
    hdt->col(2).setZero();
  }
  if (htt && definite) {  // Gauss-Newton: c (I - e_z e_z^T)
    *htt = c * Mat3::Identity();
    (*htt)(2, 2) = 0.0;
  } else if (htt) {
    const Vec3 tb = r.transpose() * t;
    const Vec3 ez = Vec3::UnitZ();
    *htt = c * tb.z() * Mat3::Identity() - 0.5 * c * (tb * ez.transpose() + ez * tb.transpose());
  }
}

void bend_twist_hessian(const Quat& a, const Quat& b, double rest, const Vec3& k, const Vec3& uhat,
                        Mat3* haa, Mat3* hab, Mat3* hbb, bool definite) {
  // r = exp(-alpha/2) r0 exp(beta/2) with r0 = conj(a) (x) b = (w, v). To first order
  // vec(r) = v + (1/2)(-w + [v]x) alpha + (1/2)(w + [v]x) beta, so u = (2 sigma/l) vec(r) has
  // Jacobians Ja, Jb below (the Gauss-Newton part J^T l K J). The second-order part of vec(r),
  // -(|alpha|^2 + |beta|^2) v/8 - (1/4) vec((0, alpha) r0 (0, beta)), contracted with e = dV/du
  // gives the rest.
  const BendParts p = bend_parts(a, b, rest, k, uhat);
  const double g = p.sigma / rest, w = p.w;
  // With S = [v]x (S^T = -S), K = diag(l k), Ja = g (S - w I) and Jb = g (S + w I), the three
  // Gauss-Newton blocks J^T K J expand into one product P = S K S and Q = K S:
  // Ja^T K Ja = g^2 (w^2 K - P - w (Q + Q^T)), Jb^T K Jb = g^2 (w^2 K - P + w (Q + Q^T)),
  // Ja^T K Jb = g^2 (w (Q^T - Q) - P - w^2 K).
  const Mat3 sv = skew(p.v);
  const Vec3 lk = rest * k;
  const Mat3 q = lk.asDiagonal() * sv;
  const Mat3 pp = sv * q;
  const Mat3 kw2 = Mat3(lk.asDiagonal()) * (w * w);
  const Mat3 qs = w * (q + q.transpose());
  const double g2 = g * g;
  const double ev = p.e.dot(p.v);
  const double diag_part = definite ? 0.0 : -0.5 * g * ev;
  if (haa) {
    *haa = g2 * (kw2 - pp - qs);
    haa->diagonal().array() += diag_part;
  }
  if (hbb) {
    *hbb = g2 * (kw2 - pp + qs);
    hbb->diagonal().array() += diag_part;
  }
  if (hab) {
    *hab = g2 * (w * (q.transpose() - q) - pp - kw2);
    if (!definite)
      *hab += (0.5 * g) * (p.v * p.e.transpose() + p.e * p.v.transpose() + w * skew(p.e) -
                           ev * Mat3::Identity());
  }
}

// ---------------------------------------------------------------------------------------------
// RodSystem

double RodSystem::energy() const {
  const Rod& r = *rod;
  const Section& sec = r.section();
  const auto& x = r.positions();
  const auto& q = r.orientations();
  const auto& rest = r.rest_lengths();
  const int n = r.num_segments();
  const Vec3 k(sec.bend, sec.bend, sec.twist);
  double e = 0.0;
  for (int s = 0; s < n; ++s) {
    const Vec3 d = x[s + 1] - x[s];
    if (terms & kStretchTerm) e += stretch_energy(d, rest[s], sec.stretch, nullptr);
    if (terms & kCouplingTerm) e += coupling_energy(d, q[s], rest[s], sec.kappa, nullptr, nullptr);
  }
  if (terms & kBendTwistTerm) {
    for (int j = 0; j + 1 < n; ++j)
      e += bend_twist_energy(q[j], q[j + 1], 0.5 * (rest[j] + rest[j + 1]), k, r.rest_strains()[j],
                             nullptr, nullptr);
    const GhostFrame &g0 = r.ghost_start(), &g1 = r.ghost_end();
    if (g0.active)
      e += bend_twist_energy(g0.frame, q[0], 0.5 * rest[0], k, g0.uhat, nullptr, nullptr);
    if (g1.active)
      e += bend_twist_energy(q[n - 1], g1.frame, 0.5 * rest[n - 1], k, g1.uhat, nullptr, nullptr);
  }
  if (terms & kGravityTerm)
    for (int i = 0; i <= n; ++i) e -= r.node_masses()[i] * gravity.dot(x[i]);
  if (terms & kLoadTerm)
    for (const Load& l : r.loads())
      if (!l.follower && l.kind == Load::Kind::kForce)
        e -= load_scale * l.scale(t) * l.value.dot(x[l.index]);
  return e;
}

void RodSystem::gradient(Eigen::VectorXd* g) const {
  const Rod& r = *rod;
  const Section& sec = r.section();
  const auto& x = r.positions();
  const auto& q = r.orientations();
  const auto& rest = r.rest_lengths();
  const int n = r.num_segments();
  const Vec3 k(sec.bend, sec.bend, sec.twist);
  g->setZero(size());
  for (int s = 0; s < n; ++s) {
    const Vec3 d = x[s + 1] - x[s];
    Vec3 gd = Vec3::Zero(), tmp;
    if (terms & kStretchTerm) {
      stretch_energy(d, rest[s], sec.stretch, &tmp);
      gd += tmp;
    }
    if (terms & kCouplingTerm) {
      coupling_energy(d, q[s], rest[s], sec.kappa, &tmp, nullptr);
      gd += tmp;
      // Body gradient = minus the coupling torque.
      g->segment<3>(segment_index(s)) -=
          coupling_torque(q[s].conjugate() * d.normalized(), rest[s], sec.kappa);
    }
    g->segment<3>(node_index(s + 1)) += gd;
    g->segment<3>(node_index(s)) -= gd;
  }
  if (terms & kBendTwistTerm) {
    // Body gradients J^T e: on a, (sigma/l)(-w e - v x e); on b, (sigma/l)(w e - v x e).
    auto element = [&](const Quat& a, const Quat& b, double l, const Vec3& uhat, int sa, int sb) {
      const BendParts p = bend_parts(a, b, l, k, uhat);
      const double gg = p.sigma / l;
      const Vec3 ve = p.v.cross(p.e);
      if (sa >= 0) g->segment<3>(segment_index(sa)) += gg * (-p.w * p.e - ve);
      if (sb >= 0) g->segment<3>(segment_index(sb)) += gg * (p.w * p.e - ve);
    };
    for (int j = 0; j + 1 < n; ++j)
      element(q[j], q[j + 1], 0.5 * (rest[j] + rest[j + 1]), r.rest_strains()[j], j, j + 1);
    const GhostFrame &g0 = r.ghost_start(), &g1 = r.ghost_end();
    if (g0.active) element(g0.frame, q[0], 0.5 * rest[0], g0.uhat, -1, 0);
    if (g1.active) element(q[n - 1], g1.frame, 0.5 * rest[n - 1], g1.uhat, n - 1, -1);
  }
  if (terms & kGravityTerm)
    for (int i = 0; i <= n; ++i) g->segment<3>(node_index(i)) -= r.node_masses()[i] * gravity;
  if (terms & kLoadTerm)
    for (const Load& l : r.loads()) {
      if (l.follower) continue;
      const double f = load_scale * l.scale(t);
      if (f == 0.0) continue;
      if (l.kind == Load::Kind::kForce)
        g->segment<3>(node_index(l.index)) -= f * l.value;
      else
        g->segment<3>(segment_index(l.index)) -= f * (q[l.index].conjugate() * l.value);
    }
}

void RodSystem::hessian(BlockTridiag* h) const {
  const Rod& r = *rod;
  const Section& sec = r.section();
  const auto& x = r.positions();
  const auto& q = r.orientations();
  const auto& rest = r.rest_lengths();
  const int n = r.num_segments();
  const Vec3 k(sec.bend, sec.bend, sec.twist);
  h->resize(blocks());
  // Each 6x6 block is assigned once, in the pass over the segments: block s (node s at offset 0,
  // segment s at offset 3) from the terms of chord s, of bending element s (segments s, s + 1)
  // and what chord s - 1 and element s - 1 leave on it; lower[s] = block (s + 1, s) from chord s
  // and element s alone. No zeroing and no read-modify-write of the blocks.
  const bool stretch = terms & kStretchTerm, coupling = terms & kCouplingTerm,
             bending = terms & kBendTwistTerm;
  const GhostFrame &g0 = r.ghost_start(), &g1 = r.ghost_end();
  Mat3 dd_prev = Mat3::Zero(), hbb_prev = Mat3::Zero();  // chord s - 1 on node s, element s - 1
  if (bending && g0.active)  // the start clamp is the element before segment 0
    bend_twist_hessian(g0.frame, q[0], 0.5 * rest[0], k, g0.uhat, nullptr, nullptr, &hbb_prev,
                       definite);
  for (int s = 0; s < n; ++s) {
    const Vec3 d = x[s + 1] - x[s];
    Mat3 dd = Mat3::Zero(), hdt = Mat3::Zero(), htt = Mat3::Zero(), hdd;
    Mat3 haa = Mat3::Zero(), hab = Mat3::Zero(), hbb = Mat3::Zero();
    if (stretch) dd = stretch_hessian(d, rest[s], sec.stretch, definite);
    if (coupling) {
      coupling_hessian(d, q[s], rest[s], sec.kappa, &hdd, &hdt, &htt, definite);
      dd += hdd;
    }
    if (bending && s + 1 < n)
      bend_twist_hessian(q[s], q[s + 1], 0.5 * (rest[s] + rest[s + 1]), k, r.rest_strains()[s],
                         &haa, &hab, &hbb, definite);
    else if (bending && g1.active)  // the end clamp is the element after the last segment
      bend_twist_hessian(q[n - 1], g1.frame, 0.5 * rest[n - 1], k, g1.uhat, &haa, nullptr, nullptr,
                         definite);
    // d = x_{s+1} - x_s: the coupling's (node, segment) blocks are +hdt for node s + 1 and -hdt
    // for node s.
    Mat6& ds = h->diag[s];
    ds.topLeftCorner<3, 3>() = dd_prev + dd;
    ds.topRightCorner<3, 3>() = -hdt;
    ds.bottomLeftCorner<3, 3>() = -hdt.transpose();
    ds.bottomRightCorner<3, 3>() = htt + haa + hbb_prev;
    Mat6& ls = h->lower[s];
    ls.topLeftCorner<3, 3>() = -dd;
    ls.topRightCorner<3, 3>() = hdt;
    ls.bottomLeftCorner<3, 3>().setZero();
    ls.bottomRightCorner<3, 3>() = hab.transpose();  // (segment s + 1, segment s)
    dd_prev = dd;
    hbb_prev = hbb;
  }
  h->diag[n].setZero();  // the last node and the unused slot
  h->diag[n].topLeftCorner<3, 3>() = dd_prev;
  // Gravity and dead force loads are linear in the positions; dead torques have a skew torque
  // Jacobian and no symmetric part: none of them adds to the Hessian.
}

}  // namespace corde
