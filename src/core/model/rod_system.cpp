#include "corde_sim/model/rod_system.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>

#include "corde_sim/math/so3.h"
#include "corde_sim/model/loads.h"

namespace corde {

namespace {

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
  const Mat3 sv = so3::skew(p.v);
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
      *hab += (0.5 * g) * (p.v * p.e.transpose() + p.e * p.v.transpose() + w * so3::skew(p.e) -
                           ev * Mat3::Identity());
  }
}

// ---------------------------------------------------------------------------------------------
// RodSystem

double RodSystem::energy() const {
  const Rod& r = *rod;
  const Section& sec = section ? *section : r.section();
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
  const std::vector<double>& masses = node_masses ? *node_masses : r.node_masses();
  if (terms & kGravityTerm) {
    for (int i = 0; i <= n; ++i) e -= masses[i] * gravity.dot(x[i]);
    // Offset centres of mass are point masses: no stand-in rate moves them.
    if (!node_masses)
      for (const Rod::MassOffset& m : r.mass_offsets()) e += m.potential(q[m.segment], gravity);
  }
  if (terms & kLoadTerm)
    for (const Load& l : r.loads())
      if (load_has_potential(l)) e -= load_work(l, load_scale * l.scale(t), x[l.index]);
  return e;
}

void RodSystem::gradient(Eigen::VectorXd* g) const {
  const Rod& r = *rod;
  const Section& sec = section ? *section : r.section();
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
  const std::vector<double>& masses = node_masses ? *node_masses : r.node_masses();
  if (terms & kGravityTerm) {
    for (int i = 0; i <= n; ++i) g->segment<3>(node_index(i)) -= masses[i] * gravity;
    // An offset centre of mass (Rod::add_mass_offset): body gradient -m d x (R^T g); a point
    // mass, so no stand-in rate moves it.
    if (!node_masses)
      for (const Rod::MassOffset& m : r.mass_offsets())
        g->segment<3>(segment_index(m.segment)) -= m.body_torque(q[m.segment], gravity);
  }
  if (terms & kLoadTerm)
    for (const Load& l : r.loads()) {
      if (l.follower) continue;
      const double f = load_scale * l.scale(t);
      if (f == 0.0) continue;
      if (l.kind == Load::Kind::kForce)
        g->segment<3>(node_index(l.index)) -= load_world(l, f, q);
      else
        g->segment<3>(segment_index(l.index)) -= load_body_torque(l, f, q[l.index]);
    }
}

void RodSystem::hessian(BlockTridiag* h) const {
  const Rod& r = *rod;
  const Section& sec = section ? *section : r.section();
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
  // Jacobian and no symmetric part: none of them adds to the Hessian, but gravity on an offset
  // centre of mass does: -m gb.(R exp(theta) d), gb = R^T g, has the body Hessian
  // m (gb.d) I - (m/2)(gb d^T + d gb^T) (its PSD part when definite).
  if (terms & kGravityTerm)
    for (const Rod::MassOffset& m : r.mass_offsets())
      h->diag[m.segment].bottomRightCorner<3, 3>() +=
          mass_offset_hessian(q[m.segment].conjugate() * gravity, m.offset, m.mass, definite);
}

Mat3 mass_offset_hessian(const Vec3& gb, const Vec3& d, double mass, bool definite) {
  Mat3 h =
      mass * gb.dot(d) * Mat3::Identity() - 0.5 * mass * (gb * d.transpose() + d * gb.transpose());
  if (!definite) return h;
  Eigen::SelfAdjointEigenSolver<Mat3> es(h);
  const Vec3 ev = es.eigenvalues().cwiseMax(0.0);
  return es.eigenvectors() * ev.asDiagonal() * es.eigenvectors().transpose();
}

}  // namespace corde
