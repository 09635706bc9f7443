#include "corde_sim/stability/explicit_step_limit.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "corde_sim/model/rod_system.h"
#include "corde_sim/world/world.h"

namespace corde {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Symmetric matrix with at most two off-diagonals: off1[i] = A(i, i+1), off2[i] = A(i, i+2).
struct Band {
  std::vector<double> diag, off1, off2;
  explicit Band(int n) : diag(n, 0.0), off1(n, 0.0), off2(n, 0.0) {}
  int size() const { return static_cast<int>(diag.size()); }
  double at(int i, int j) const {  // i <= j
    const int d = j - i;
    return d == 0 ? diag[i] : d == 1 ? off1[i] : d == 2 ? off2[i] : 0.0;
  }
  // Adds k g g^T on consecutive indices i0 .. i0 + g.size() - 1 (g.size() <= 3).
  void add_outer(int i0, const std::vector<double>& g, double k) {
    for (size_t a = 0; a < g.size(); ++a)
      for (size_t b = a; b < g.size(); ++b) {
        const double v = k * g[a] * g[b];
        const int i = i0 + static_cast<int>(a);
        if (b == a)
          diag[i] += v;
        else if (b == a + 1)
          off1[i] += v;
        else
          off2[i] += v;
      }
  }
};

// The matrix restricted to the free degrees of freedom and scaled to M^-1/2 A M^-1/2. Dropping
// rows and columns of a banded matrix keeps it banded.
Band reduce(const Band& a, const std::vector<double>& mass, const std::vector<bool>& free) {
  std::vector<int> idx;
  for (int i = 0; i < a.size(); ++i)
    if (free[i]) idx.push_back(i);
  Band r(static_cast<int>(idx.size()));
  for (int p = 0; p < r.size(); ++p) {
    const int i = idx[p];
    r.diag[p] = a.diag[i] / mass[i];
    for (int d = 1; d <= 2 && p + d < r.size(); ++d) {
      const int j = idx[p + d];
      if (j - i > 2) continue;
      const double v = a.at(i, j) / std::sqrt(mass[i] * mass[j]);
      (d == 1 ? r.off1 : r.off2)[p] = v;
    }
  }
  return r;
}

// LDL^T of A - sigma I without pivoting; by Sylvester's law of inertia the number of negative
// pivots is the number of eigenvalues below sigma (a Sturm count for a banded matrix).
struct Ldl {
  std::vector<double> d, l1, l2;  // l1[j] = L(j, j-1), l2[j] = L(j, j-2)
  int negatives = 0;
};

Ldl factor(const Band& a, double sigma) {
  const int n = a.size();
  Ldl f;
  f.d.assign(n, 0.0);
  f.l1.assign(n, 0.0);
  f.l2.assign(n, 0.0);
  const double tiny = 1e-300;
  for (int i = 0; i < n; ++i) {
    double s = a.diag[i] - sigma;
    if (i >= 1) s -= f.l1[i] * f.l1[i] * f.d[i - 1];
    if (i >= 2) s -= f.l2[i] * f.l2[i] * f.d[i - 2];
    if (std::abs(s) < tiny) s = -tiny;
    f.d[i] = s;
    if (s < 0.0) ++f.negatives;
    if (i + 1 < n) {  // L(i+1, i) = (A(i+1, i) - L(i+1, i-1) L(i, i-1) D(i-1)) / D(i)
      double t = a.off1[i];
      if (i >= 1) t -= f.l2[i + 1] * f.l1[i] * f.d[i - 1];
      f.l1[i + 1] = t / s;
    }
    if (i + 2 < n) f.l2[i + 2] = a.off2[i] / s;
  }
  return f;
}

// Highest eigenvalue of a symmetric positive semidefinite band matrix: Sturm counts bisected
// below its Gershgorin bound.
double top_eigenvalue(const Band& a) {
  const int n = a.size();
  double hi = 0.0;
  for (int i = 0; i < n; ++i) {
    double row = a.diag[i];
    for (int j = std::max(0, i - 2); j <= std::min(n - 1, i + 2); ++j)
      if (j != i) row += std::abs(j < i ? a.at(j, i) : a.at(i, j));
    hi = std::max(hi, row);
  }
  if (!(hi > 0.0)) return 0.0;
  double lo = 0.0;
  hi *= 1.0 + 1e-12;
  for (int it = 0; it < 200 && hi - lo > 1e-13 * hi; ++it) {
    const double mid = 0.5 * (lo + hi);
    (factor(a, mid).negatives == n ? hi : lo) = mid;
  }
  return hi;
}

// Critical step of one family with mass-scaled stiffness k and friction d (from the old
// velocity). Semi-implicit Euler keeps v^T (I - h^2 K/4 - h D/2) v + x_mid^T K x_mid from growing
// (v the new velocity, x_mid the mean of consecutive positions), so it is stable while
// h^2 K + 2 h D < 4 I and generically unstable beyond: for commuting K, D each mode's
// h^2 omega^2 + 2 h c < 4. In general the limiting vector is neither K's nor D's top eigenvector
// (friction on the light tilts against K's top penalty mode on the nodes), hence the bisection
// on Sturm counts of h^2 K + 2 h D - 4 I. omega2 returns K's top eigenvalue.
double family_step(const Band& k, const Band& d, double* omega2) {
  const int n = k.size();
  const double w2 = top_eigenvalue(k), c = top_eigenvalue(d);
  *omega2 = w2;
  if (!(w2 > 0.0) && !(c > 0.0)) return kInf;
  // Undamped: 2/omega, computed as before (validated against measured edges).
  if (!(c > 0.0)) return std::sqrt(4.0 * w2) / w2;
  // Both K's and D's top eigenvectors must satisfy the condition on their own, so h is below
  // 2/omega and 2/c.
  double lo = 0.0, hi = 2.0 / c;
  if (w2 > 0.0) hi = std::min(hi, 2.0 / std::sqrt(w2));
  Band a(n);
  for (int it = 0; it < 200 && hi - lo > 1e-13 * hi; ++it) {
    const double h = 0.5 * (lo + hi);
    for (int i = 0; i < n; ++i) {
      a.diag[i] = h * h * k.diag[i] + 2.0 * h * d.diag[i];
      a.off1[i] = h * h * k.off1[i] + 2.0 * h * d.off1[i];
      a.off2[i] = h * h * k.off2[i] + 2.0 * h * d.off2[i];
    }
    (factor(a, 4.0).negatives == n ? lo : hi) = h;
  }
  return lo;
}

}  // namespace

StabilityEstimate estimate_stability(const Rod& rod) {
  const Section& sec = rod.section();
  const int n = rod.num_segments();
  const std::vector<double>& rest = rod.rest_lengths();
  std::vector<double> elem(std::max(0, n - 1));
  for (int j = 0; j + 1 < n; ++j) elem[j] = 0.5 * (rest[j] + rest[j + 1]);
  std::vector<bool> node_free(n + 1, true), seg_free(n, true);
  for (const NodeDrive& d : rod.node_drives()) node_free[d.node] = false;
  for (const SegmentDrive& d : rod.segment_drives()) seg_free[d.segment] = false;
  const bool ghost0 = rod.ghost_start().active, ghost1 = rod.ghost_end().active;

  // Stretch: axial node displacements, springs K_s/l and dashpots gamma_t/l per segment.
  Band ks(n + 1), ds(n + 1);
  for (int s = 0; s < n; ++s) {
    ks.add_outer(s, {-1.0, 1.0}, sec.stretch / rest[s]);
    ds.add_outer(s, {-1.0, 1.0}, sec.gamma_t / rest[s]);
  }
  // Twist: segment rotations about d3, springs C/l per element (ghost elements: half length,
  // no friction).
  Band kt(n), dt(n);
  for (int j = 0; j + 1 < n; ++j) {
    kt.add_outer(j, {-1.0, 1.0}, sec.twist / elem[j]);
    dt.add_outer(j, {-1.0, 1.0}, sec.gamma_r / elem[j]);
  }
  if (ghost0) kt.diag[0] += sec.twist / (0.5 * rest[0]);
  if (ghost1) kt.diag[n - 1] += sec.twist / (0.5 * rest[n - 1]);
  // Bending-shear in one plane: unknowns w_0, psi_0, w_1, ..., psi_{N-1}, w_N (node transverse
  // displacement, segment tilt). Penalty kappa/(2l) (w_{s+1} - w_s - l psi_s)^2 per segment,
  // frame bending B/(2l) (psi_{j+1} - psi_j)^2 per element; friction on the tilts only.
  Band kb(2 * n + 1), db(2 * n + 1);
  for (int s = 0; s < n; ++s) kb.add_outer(2 * s, {-1.0, -rest[s], 1.0}, sec.kappa / rest[s]);
  for (int j = 0; j + 1 < n; ++j) {
    kb.diag[2 * j + 1] += sec.bend / elem[j];
    kb.diag[2 * j + 3] += sec.bend / elem[j];
    kb.off2[2 * j + 1] -= sec.bend / elem[j];
    db.diag[2 * j + 1] += sec.gamma_r / elem[j];
    db.diag[2 * j + 3] += sec.gamma_r / elem[j];
    db.off2[2 * j + 1] -= sec.gamma_r / elem[j];
  }
  if (ghost0) kb.diag[1] += sec.bend / (0.5 * rest[0]);
  if (ghost1) kb.diag[2 * n - 1] += sec.bend / (0.5 * rest[n - 1]);

  std::vector<double> twist_mass(n), bend_mass(2 * n + 1);
  std::vector<bool> bend_free(2 * n + 1);
  for (int s = 0; s < n; ++s) {
    twist_mass[s] = rod.segment_inertia(s).z();
    bend_mass[2 * s + 1] = rod.segment_inertia(s).x();
    bend_free[2 * s + 1] = seg_free[s];
  }
  for (int i = 0; i <= n; ++i) {
    bend_mass[2 * i] = rod.node_masses()[i];
    bend_free[2 * i] = node_free[i];
  }
  const std::vector<double>& node_mass = rod.node_masses();
  double w2_stretch = 0.0, w2_twist = 0.0, w2_bend = 0.0;
  StabilityEstimate e;
  e.stretch =
      family_step(reduce(ks, node_mass, node_free), reduce(ds, node_mass, node_free), &w2_stretch);
  e.twist =
      family_step(reduce(kt, twist_mass, seg_free), reduce(dt, twist_mass, seg_free), &w2_twist);
  e.bending =
      family_step(reduce(kb, bend_mass, bend_free), reduce(db, bend_mass, bend_free), &w2_bend);
  e.omega_max = std::sqrt(std::max({w2_stretch, w2_twist, w2_bend}));
  e.time_step = std::min({e.stretch, e.twist, e.bending});
  e.limiting = e.time_step == e.stretch ? "stretch"
               : e.time_step == e.twist ? "twist"
                                        : "bending-shear";
  return e;
}

double critical_time_step(const Rod& rod) { return estimate_stability(rod).time_step; }

namespace {

// The rod's mass-scaled stiffness M^-1/2 K M^-1/2 and friction M^-1/2 D M^-1/2 at its current
// state, in model/rod_system.h's blocks; kinematic items and the unused slot are zero rows and
// columns.
struct ScaledSystem {
  BlockTridiag k, d;
  std::vector<bool> free;  // per unknown
  bool damped = false;
};

ScaledSystem scaled_system(const Rod& rod) {
  ScaledSystem s;
  RodSystem sys;
  sys.rod = &rod;
  sys.terms = kStretchTerm | kCouplingTerm | kBendTwistTerm;  // gravity, dead loads: linear
  sys.hessian(&s.k);
  const int nb = sys.blocks(), n = rod.num_segments(), size = sys.size();
  s.d.resize(nb);
  s.d.set_zero();
  const Section& sec = rod.section();
  const auto& x = rod.positions();
  const auto& q = rod.orientations();
  const auto& rest = rod.rest_lengths();
  // Friction as the explicit step applies it: gamma_t / l on the chord's rate along its tangent,
  // gamma_r / l on the difference of the neighbours' world angular velocities (ghost elements
  // none). Body rates w map to world ones by R.
  if (sec.gamma_t > 0.0)
    for (int i = 0; i < n; ++i) {
      const Vec3 t = (x[i + 1] - x[i]).normalized();
      const Mat3 m = (sec.gamma_t / rest[i]) * t * t.transpose();
      const int a = RodSystem::node_index(i), b = RodSystem::node_index(i + 1);
      s.d.add(a, a, m);
      s.d.add(b, b, m);
      s.d.add(b, a, -m);
    }
  if (sec.gamma_r > 0.0)
    for (int j = 0; j + 1 < n; ++j) {
      const double g = sec.gamma_r / (0.5 * (rest[j] + rest[j + 1]));
      const int a = RodSystem::segment_index(j), b = RodSystem::segment_index(j + 1);
      s.d.add(a, a, g * Mat3::Identity());
      s.d.add(b, b, g * Mat3::Identity());
      s.d.add(b, a, -g * (q[j + 1].toRotationMatrix().transpose() * q[j].toRotationMatrix()));
    }
  s.damped = sec.gamma_t > 0.0 || sec.gamma_r > 0.0;
  // Inverse square roots of the masses; zero removes the unknown.
  std::vector<double> w(size, 0.0);
  s.free.assign(size, false);
  std::vector<bool> node_free(n + 1, true), seg_free(n, true);
  for (const NodeDrive& dr : rod.node_drives()) node_free[dr.node] = false;
  for (const SegmentDrive& dr : rod.segment_drives()) seg_free[dr.segment] = false;
  for (int i = 0; i <= n; ++i)
    if (node_free[i] && rod.node_masses()[i] > 0.0)
      for (int c = 0; c < 3; ++c) {
        w[RodSystem::node_index(i) + c] = 1.0 / std::sqrt(rod.node_masses()[i]);
        s.free[RodSystem::node_index(i) + c] = true;
      }
  for (int j = 0; j < n; ++j)
    if (seg_free[j])
      for (int c = 0; c < 3; ++c)
        if (rod.segment_inertia(j)[c] > 0.0) {
          w[RodSystem::segment_index(j) + c] = 1.0 / std::sqrt(rod.segment_inertia(j)[c]);
          s.free[RodSystem::segment_index(j) + c] = true;
        }
  for (BlockTridiag* m : {&s.k, &s.d}) {
    for (int b = 0; b < nb; ++b)
      for (int r = 0; r < 6; ++r)
        for (int c = 0; c < 6; ++c) {
          m->diag[b](r, c) *= w[6 * b + r] * w[6 * b + c];
          if (b + 1 < nb) m->lower[b](r, c) *= w[6 * b + 6 + r] * w[6 * b + c];
        }
  }
  return s;
}

// True when a I - b K - c D is positive definite (removed unknowns: identity rows).
bool definite(const ScaledSystem& s, double a, double b, double c, BlockTridiag* m,
              BlockTridiagSolver* solver) {
  const int nb = s.k.blocks();
  m->resize(nb);
  for (int k = 0; k < nb; ++k) {
    m->diag[k] = -b * s.k.diag[k] - c * s.d.diag[k];
    if (k + 1 < nb) m->lower[k] = -b * s.k.lower[k] - c * s.d.lower[k];
    for (int r = 0; r < 6; ++r) m->diag[k](r, r) += s.free[6 * k + r] ? a : 1.0;
  }
  return solver->factor(*m);
}

// Gershgorin bound on the top eigenvalue of a block tridiagonal matrix.
double gershgorin(const BlockTridiag& a) {
  const int nb = a.blocks();
  double hi = 0.0;
  for (int k = 0; k < nb; ++k)
    for (int r = 0; r < 6; ++r) {
      double row = a.diag[k](r, r);
      for (int c = 0; c < 6; ++c)
        if (c != r) row += std::abs(a.diag[k](r, c));
      if (k + 1 < nb) row += a.lower[k].row(r).cwiseAbs().sum();
      if (k > 0) row += a.lower[k - 1].col(r).cwiseAbs().sum();
      hi = std::max(hi, row);
    }
  return hi;
}

}  // namespace

StateStabilityEstimate estimate_stability_at_state(const Rod& rod) {
  StateStabilityEstimate e;
  const ScaledSystem s = scaled_system(rod);
  BlockTridiag m;
  BlockTridiagSolver solver;
  // Top eigenvalue of K: sigma I - K is definite above it.
  double lo = 0.0, hi = gershgorin(s.k) * (1.0 + 1e-12);
  double w2 = 0.0;
  if (hi > 0.0 && !definite(s, 1e-14 * hi, 1.0, 0.0, &m, &solver)) {
    // K has an eigenvalue above round-off (a free or collapsed rod may have none).
    for (int it = 0; it < 200 && hi - lo > 1e-13 * hi; ++it) {
      const double mid = 0.5 * (lo + hi);
      (definite(s, mid, 1.0, 0.0, &m, &solver) ? hi : lo) = mid;
    }
    w2 = hi;
  }
  e.omega_max = std::sqrt(w2);
  double c = 0.0;  // top eigenvalue of D
  if (s.damped) {
    double dlo = 0.0, dhi = gershgorin(s.d) * (1.0 + 1e-12);
    for (int it = 0; it < 200 && dhi > 0.0 && dhi - dlo > 1e-13 * dhi; ++it) {
      const double mid = 0.5 * (dlo + dhi);
      (definite(s, mid, 0.0, -1.0, &m, &solver) ? dhi : dlo) = mid;
    }
    c = dhi;
  }
  if (!(w2 > 0.0) && !(c > 0.0)) {
    e.time_step = kInf;
    return e;
  }
  if (!(c > 0.0)) {
    e.time_step = 2.0 / std::sqrt(w2);
  } else {
    // 4 I - h^2 K - 2 h D definite: bisected below the bounds of K's and D's top vectors.
    double h_lo = 0.0, h_hi = 2.0 / c;
    if (w2 > 0.0) h_hi = std::min(h_hi, 2.0 / std::sqrt(w2));
    for (int it = 0; it < 200 && h_hi - h_lo > 1e-13 * h_hi; ++it) {
      const double h = 0.5 * (h_lo + h_hi);
      (definite(s, 4.0, h * h, 2.0 * h, &m, &solver) ? h_lo : h_hi) = h;
    }
    e.time_step = h_lo;
  }
  // Where K's top mode lives: inverse iteration just above its eigenvalue.
  if (w2 > 0.0 && definite(s, w2 * (1.0 + 1e-6), 1.0, 0.0, &m, &solver)) {
    Eigen::VectorXd v = Eigen::VectorXd::Ones(s.k.size());
    for (int i = 0; i < v.size(); ++i)
      if (!s.free[i]) v[i] = 0.0;
    for (int it = 0; it < 8; ++it) {
      solver.solve(&v);
      for (int i = 0; i < v.size(); ++i)
        if (!s.free[i]) v[i] = 0.0;
      v.normalize();
    }
    double best = -1.0, rot = 0.0;
    for (int b = 0; b < s.k.blocks(); ++b) {
      const double tn = v.segment<3>(6 * b).squaredNorm(),
                   rn = v.segment<3>(6 * b + 3).squaredNorm();
      rot += rn;
      if (std::max(tn, rn) > best) {
        best = std::max(tn, rn);
        e.block = b;
      }
    }
    e.rotation_share = rot;
  }
  return e;
}

namespace {

// The lower of the rest limit and the state's: at the rest state both agree to their
// bisections' 1e-13, and the rest value is kept there exactly.
bool state_is_lower(double state, double rest) { return state < rest * (1.0 - 1e-9); }

}  // namespace

double state_critical_time_step(const Rod& rod) {
  const double rest = critical_time_step(rod), state = estimate_stability_at_state(rod).time_step;
  return state_is_lower(state, rest) ? state : rest;
}

WorldStepLimit explicit_step_limit(const World& world, bool at_state) {
  WorldStepLimit out;
  for (size_t r = 0; r < world.rods().size(); ++r) {
    const Rod& rod = world.rods()[r];
    const StabilityEstimate rest = estimate_stability(rod);
    double h = rest.time_step;
    std::string limiting = rest.limiting;
    if (at_state) {
      const double state = estimate_stability_at_state(rod).time_step;
      if (state_is_lower(state, h)) {
        h = state;
        limiting = "start shape";
      }
    }
    if (out.rod < 0 || std::isnan(h) || h < out.time_step) {
      out.time_step = h;
      out.rod = static_cast<int>(r);
      out.limiting = limiting;
    }
  }
  return out;
}

double lifting_inertia_scale(const Rod& rod) {
  Rod r = rod;
  r.set_rotational_inertia_scale(1.0);
  const StabilityEstimate e1 = estimate_stability(r);
  double target = std::min(e1.stretch, e1.twist);
  if (!(e1.bending < 0.99 * target)) return 1.0;
  // Very heavy tilts leave the penalty acting on the nodes alone: what no scale can lift.
  r.set_rotational_inertia_scale(1e12);
  target = std::min(target, estimate_stability(r).bending);
  // While the tilts' penalty mode limits, the bending-shear step grows as sqrt(scale): a
  // fixed-point iteration on that law, then a bisection in log(scale) for the smallest scale.
  double lo = 1.0, hi = 1.0, step = e1.bending;
  for (int it = 0; it < 60 && step < 0.99 * target; ++it) {
    lo = hi;
    hi = std::min(1e12, hi * std::max(1.01, std::pow(0.99 * target / step, 2)));
    r.set_rotational_inertia_scale(hi);
    step = estimate_stability(r).bending;
  }
  for (int it = 0; it < 30 && hi > lo * 1.001; ++it) {
    const double mid = std::sqrt(lo * hi);
    r.set_rotational_inertia_scale(mid);
    (estimate_stability(r).bending < 0.99 * target ? lo : hi) = mid;
  }
  return hi;
}

}  // namespace corde
