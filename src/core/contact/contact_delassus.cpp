// The coupled contact solve on the Delassus operator (ContactSettings::Solver::kDelassus), for the
// implicit integrators: the impulses p of the step's contacts change the contact points' relative
// velocities by u = W p, W = J C J^T, C the rods' compliance over the step (the factorised Newton
// matrix's inverse, ContactResponse::response, one banded solve per rod) and J the contacts' node
// weights. The impulses solve the contact conditions (no contact closes past its target, exact
// Coulomb friction, docs/model.md "Contacts") by an accelerated projected gradient (APGD:
// Nesterov's method with adaptive restart and a backtracked step, after Mazhar, Heyn, Negrut and
// Tasora, ACM TOG 34(3), 2015) in the metric of each contact's own block of W, which the response
// gives exactly (ContactResponse::node_compliance, selected inversion of the banded factor). Each
// iteration applies W once, matrix-free; many contacts loading one stiff rod, whose exact blocks
// the lumped masses of the rounds misjudge by the rod's whole mass, then converge in few.
#include <algorithm>
#include <cmath>

#include "contact_velocity.h"
#include "corde_sim/contact/contact.h"
#include "corde_sim/contact/contact_response.h"
#include "corde_sim/world/world.h"

namespace corde {
namespace {

// The part of v in the plane normal to the unit vector n.
Vec3 tangential(const Vec3& v, const Vec3& n) { return v - n * n.dot(v); }

// A unit vector perpendicular to v.
Vec3 perpendicular(const Vec3& v) {
  const Vec3 a = std::abs(v.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY();
  return v.cross(a).normalized();
}

// The compliance block of a contact point at s along segment i of a rod: (1 - s)^2 C_ii +
// s (1 - s) (C_{i+1,i} + C_{i+1,i}^T) + s^2 C_{i+1,i+1}.
Mat3 point_block(const std::vector<Mat3>& diag, const std::vector<Mat3>& lower, int i, double s) {
  const double a = 1.0 - s;
  Mat3 w = (a * a) * diag[i] + (s * s) * diag[i + 1];
  w += (a * s) * (lower[i] + lower[i].transpose());
  return w;
}

}  // namespace

void ContactSystem::mark_touched(const World& world, const ContactResponse& response) {
  const int nr = static_cast<int>(world.rods().size());
  touched_.assign(nr, 0);
  for (int r = 0; r < nr; ++r) touched_[r] = response.has_prediction(r) ? 1 : 0;
  for (const Contact& c : contacts_) {
    touched_[c.rod_a] = 1;
    if (c.rod_b >= 0) touched_[c.rod_b] = 1;
  }
}

void ContactSystem::remember_impulses(int nr) {
  last_impulse_.resize(nr);
  last_torque_.resize(nr);
  for (int r = 0; r < nr; ++r) {
    if (touched_[r])
      last_impulse_[r] = impulse_[r];
    else
      last_impulse_[r].clear();
    if (touched_[r] && spin_)
      last_torque_[r] = torque_[r];
    else
      last_torque_[r].clear();
  }
}

bool ContactSystem::solve_delassus(World& world, double h, ContactResponse& response) {
  auto& rods = world.rods();
  const int nr = static_cast<int>(rods.size());
  const ContactSettings& cs = world.contact;
  const size_t nc = contacts_.size();
  mark_touched(world, response);
  impulse_.resize(nr);
  change_v_.resize(nr);
  rows_.resize(nc);
  for (size_t k = 0; k < nc; ++k) {
    rows_[k].target = normal_target(contacts_[k], cs, h);
    rows_[k].radius = rods[contacts_[k].rod_a].section().radius;
    rows_[k].wn = 1.0;  // measured until the blocks are known (below)
  }
  // Node impulses of the contacts' impulses p (one Vec3 per contact) into impulse_.
  auto gather = [&](const std::vector<Vec3>& p) {
    for (int r = 0; r < nr; ++r)
      if (touched_[r]) impulse_[r].assign(rods[r].num_nodes(), Vec3::Zero());
    for (size_t k = 0; k < nc; ++k) {
      const Contact& c = contacts_[k];
      impulse_[c.rod_a][c.seg_a] += (1.0 - c.s_a) * p[k];
      impulse_[c.rod_a][c.seg_a + 1] += c.s_a * p[k];
      if (c.rod_b >= 0) {
        impulse_[c.rod_b][c.seg_b] -= (1.0 - c.s_b) * p[k];
        impulse_[c.rod_b][c.seg_b + 1] -= c.s_b * p[k];
      }
    }
  };
  // Contact k's relative velocity from per-rod node velocities (absolute: less the obstacle's).
  auto relative = [&](const std::vector<std::vector<Vec3>>& vel, size_t k, bool absolute) {
    return relative_velocity(contacts_[k], vel, absolute);
  };
  // The warm-started impulses and the rods' true response to them.
  lam_.resize(nc);
  for (size_t k = 0; k < nc; ++k) lam_[k] = contacts_[k].pn * contacts_[k].normal + contacts_[k].pt;
  gather(lam_);
  for (int r = 0; r < nr; ++r) {
    if (!touched_[r]) continue;
    response.respond(rods[r], r, impulse_[r], nullptr);
    velocity_[r] = rods[r].velocities();
  }
  u_lam_.resize(nc);
  for (size_t k = 0; k < nc; ++k) u_lam_[k] = relative(velocity_, k, true);
  const double tolerance = coupled_tolerance(world, h);  // as the rounds'
  // How far impulses p with relative velocities u leave the contact conditions over the step, in
  // radii: a contact closing past its target, one carrying impulse while it separates, one
  // sticking while it slips, one sliding other than against its friction. Contacts that cannot
  // move (both sides held) or are held at their cap are not measured.
  auto residual = [&](const std::vector<Vec3>& p, const std::vector<Vec3>& u) {
    double worst = 0.0;
    for (size_t k = 0; k < nc; ++k) {
      const Contact& c = contacts_[k];
      const DelassusRow& row = rows_[k];
      if (!(row.wn > 0.0)) continue;
      const double pn = p[k].dot(c.normal);
      const double vn = u[k].dot(c.normal) - row.target;
      const bool capped = any_cap_ && pn >= cap_[k];
      double e = capped ? 0.0 : std::max(0.0, -vn);
      if (pn > 0.0) {
        e = std::max(e, capped ? 0.0 : vn);
        const Vec3 ut = tangential(u[k], c.normal);
        const Vec3 pt = tangential(p[k], c.normal);
        const double ptn = pt.norm();
        if (ptn < c.mu * pn * (1.0 - 1e-9))
          e = std::max(e, ut.norm());
        else if (ptn > 0.0)
          e = std::max(e, (ut + ut.norm() / ptn * pt).norm());
      }
      worst = std::max(worst, h * e / row.radius);
    }
    return worst;
  };
  // The projection onto the feasible impulses: pn >= 0 (within a deep contact's cap), the
  // tangential part within the Coulomb disc of that pn.
  auto project = [&](size_t k, const Vec3& p) {
    const Contact& c = contacts_[k];
    double pn = std::max(0.0, p.dot(c.normal));
    if (any_cap_) pn = std::min(pn, cap_[k]);
    Vec3 pt = tangential(p, c.normal);
    const double ptn = pt.norm(), limit = c.mu * pn;
    if (ptn > limit) pt *= limit / ptn;
    return Vec3(pn * c.normal + pt);
  };
  // Each contact's block of W, reduced to a normal and an isotropic tangential compliance (the
  // block's largest in the tangent plane): with one scalar for both tangents the fixed point
  // slides exactly against the slip, as Coulomb's law wants. Only when the warm start does not
  // already meet the tolerance (a resting scene mostly does).
  auto blocks = [&] {
    comp_diag_.resize(nr);
    comp_lower_.resize(nr);
    for (int r = 0; r < nr; ++r)
      if (touched_[r] && !response.node_compliance(rods[r], r, &comp_diag_[r], &comp_lower_[r]))
        return false;
    for (size_t k = 0; k < nc; ++k) {
      const Contact& c = contacts_[k];
      Mat3 w = point_block(comp_diag_[c.rod_a], comp_lower_[c.rod_a], c.seg_a, c.s_a);
      if (c.rod_b >= 0) w += point_block(comp_diag_[c.rod_b], comp_lower_[c.rod_b], c.seg_b, c.s_b);
      const Vec3 t1 = perpendicular(c.normal), t2 = c.normal.cross(t1);
      const double a = t1.dot(w * t1), b = 0.5 * (t1.dot(w * t2) + t2.dot(w * t1)),
                   d = t2.dot(w * t2);
      rows_[k].wn = c.normal.dot(w * c.normal);
      rows_[k].wt = 0.5 * (a + d) + std::sqrt(0.25 * (a - d) * (a - d) + b * b);
    }
    return true;
  };
  hat_ = lam_;
  u_hat_ = u_lam_;
  trial_.resize(nc);
  du_.resize(nc);
  best_ = lam_;
  double best = residual(lam_, u_lam_);
  // Without blocks (no compliance from the response) the rounds solve it (from the start).
  if (best > tolerance && nc > 0 && !blocks()) return false;
  double theta = 1.0;
  // The step's scale, in the metric of the contacts' own blocks (1: exact for one contact alone),
  // started from the last step's.
  double lip = std::max(1.0, delassus_scale_);
  int iterations = 0;
  while (best > tolerance && iterations < cs.implicit_iterations) {
    // The projected gradient step from the extrapolated point, backtracked until the step's
    // curvature (d W d against d D d) is within the scale.
    double dwd = 0.0, ddd = 0.0, largest = 0.0, change = 0.0;
    for (;;) {
      ++iterations;
      for (size_t k = 0; k < nc; ++k) {
        const Contact& c = contacts_[k];
        const DelassusRow& row = rows_[k];
        if (!(row.wn > 0.0)) {
          trial_[k] = lam_[k];
          continue;
        }
        const Vec3& u = u_hat_[k];
        const double gn = u.dot(c.normal) - row.target;
        const Vec3 gt = tangential(u, c.normal);
        trial_[k] = project(k, hat_[k] - (gn / (lip * row.wn)) * c.normal -
                                   (row.wt > 0.0 ? Vec3(gt / (lip * row.wt)) : Vec3::Zero()));
      }
      for (size_t k = 0; k < nc; ++k) du_[k] = trial_[k] - hat_[k];
      gather(du_);
      for (int r = 0; r < nr; ++r)
        if (touched_[r]) response.response(rods[r], r, impulse_[r], &change_v_[r], nullptr);
      dwd = ddd = largest = change = 0.0;
      for (size_t k = 0; k < nc; ++k) {
        const Contact& c = contacts_[k];
        const Vec3 d = du_[k];
        const double dn = d.dot(c.normal);
        ddd += rows_[k].wn * dn * dn + rows_[k].wt * tangential(d, c.normal).squaredNorm();
        du_[k] = relative(change_v_, k, false);
        dwd += d.dot(du_[k]);
        largest = std::max(largest, trial_[k].norm());
        change = std::max(change, d.norm());
      }
      if (!(dwd > lip * ddd * (1.0 + 1e-9)) || iterations >= cs.implicit_iterations) break;
      lip = std::max(2.0 * lip, dwd / ddd);
    }
    for (size_t k = 0; k < nc; ++k) du_[k] += u_hat_[k];  // the trial's relative velocities
    const double res = residual(trial_, du_);
    if (res < best) {
      best = res;
      best_ = trial_;
    }
    if (res <= tolerance || change <= 1e-12 * largest) break;
    // Nesterov's extrapolation, restarted where the gradient at the extrapolated point opposes the
    // step just made (O'Donoghue and Candes' adaptive restart, as APGD does).
    double ascent = 0.0;
    for (size_t k = 0; k < nc; ++k) {
      const Contact& c = contacts_[k];
      ascent += (u_hat_[k] - rows_[k].target * c.normal).dot(trial_[k] - lam_[k]);
    }
    double beta = 0.0;
    if (ascent > 0.0) {
      theta = 1.0;
    } else {
      const double next = 0.5 * (-theta * theta + theta * std::sqrt(theta * theta + 4.0));
      beta = theta * (1.0 - theta) / (theta * theta + next);
      theta = next;
    }
    for (size_t k = 0; k < nc; ++k) {
      hat_[k] = trial_[k] + beta * (trial_[k] - lam_[k]);
      u_hat_[k] = du_[k] + beta * (du_[k] - u_lam_[k]);
      lam_[k] = trial_[k];
      u_lam_[k] = du_[k];
    }
    lip = std::max(1.0, 0.9 * lip);
  }
  delassus_scale_ = lip;
  stats_.delassus_iterations = iterations;
  stats_.residual = best;
  stats_.tolerance = tolerance;
  // Short of the tolerance at the limit (a violent impact): the rounds go on from the best
  // impulses, so that the step is never left less resolved than the rounds leave it.
  if (best > tolerance && iterations > 0) {
    for (size_t k = 0; k < nc; ++k) {
      Contact& c = contacts_[k];
      c.pn = best_[k].dot(c.normal);
      c.pt = tangential(best_[k], c.normal);
    }
    return false;
  }
  // The best impulses, and the rods' true response to them as their state (the warm start's is
  // already).
  if (iterations > 0) {
    for (size_t k = 0; k < nc; ++k) {
      Contact& c = contacts_[k];
      c.pn = best_[k].dot(c.normal);
      c.pt = tangential(best_[k], c.normal);
    }
    gather(best_);
    for (int r = 0; r < nr; ++r) {
      if (!touched_[r]) continue;
      response.respond(rods[r], r, impulse_[r], nullptr);
      velocity_[r] = rods[r].velocities();
    }
  }
  remember_impulses(nr);
  return true;
}

}  // namespace corde
