#include "corde_sim/stability.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

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
