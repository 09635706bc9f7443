#include "corde_sim/contact/contact.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <tuple>
#include <utility>

#include "contact_velocity.h"
#include "corde_sim/contact/contact_response.h"
#include "corde_sim/contact/segment_distance.h"
#include "corde_sim/math/so3.h"
#include "corde_sim/world/world.h"

namespace corde {
namespace {

// A key that names a contact pair across steps (for the warm start).
std::uint64_t pair_key(const Contact& c) {
  const std::uint64_t other =
      c.rod_b >= 0
          ? (static_cast<std::uint64_t>(c.rod_b) << 20 | static_cast<std::uint64_t>(c.seg_b))
          : (std::uint64_t{1} << 40 | static_cast<std::uint64_t>(c.obstacle));
  // A segment's contacts at its start node, inside and at its end node are different pairs.
  const std::uint64_t where = c.s_a <= 0.0 ? 0 : c.s_a >= 1.0 ? 2 : 1;
  return (static_cast<std::uint64_t>(c.rod_a) << 54) ^ (static_cast<std::uint64_t>(c.seg_a) << 43) ^
         (where << 41) ^ other;
}

constexpr double kNoCap = std::numeric_limits<double>::infinity();

// Cell coordinates packed in 21 bits each (offset so that negatives fit).
std::uint64_t cell_key(std::int64_t x, std::int64_t y, std::int64_t z) {
  const std::int64_t o = 1 << 20;
  auto c = [&](std::int64_t v) {
    return static_cast<std::uint64_t>(std::clamp<std::int64_t>(v + o, 0, (1 << 21) - 1));
  };
  return c(x) << 42 | c(y) << 21 | c(z);
}

// A unit vector perpendicular to v.
Vec3 any_perpendicular(const Vec3& v) {
  const Vec3 a = std::abs(v.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY();
  return v.cross(a).normalized();
}

// The block t^T k t of a 3x3 matrix in the tangent plane spanned by t1, t2.
Eigen::Matrix2d tangent_block(const Mat3& k, const Vec3& t1, const Vec3& t2) {
  Eigen::Matrix2d b;
  b << t1.dot(k * t1), t1.dot(k * t2), t2.dot(k * t1), t2.dot(k * t2);
  return b;
}

// v shortened to length `limit` where it is longer: the Coulomb disc of friction, rolling
// resistance's disc.
Vec3 within(const Vec3& v, double limit) {
  const double n2 = v.squaredNorm();
  return n2 > limit * limit ? Vec3(v * (limit / std::sqrt(n2))) : v;
}

// The part of v in the plane normal to the unit vector n.
Vec3 tangential(const Vec3& v, const Vec3& n) { return v - n * n.dot(v); }

// Whether the sweeps track the segments' angular velocities (friction's moments, rolling
// resistance's couples).
bool tracks_spin(const ContactSettings& cs) {
  return cs.surface_friction || cs.rolling_friction > 0.0;
}

// The world inverse inertia of segment s as a contact's torque sees it: none for a kinematic
// segment (a drive or a grasp holds it), about the axis only for one constrained to turn about
// an axis, R diag(1/I) R^T for a free one.
Mat3 segment_inverse_inertia(const Rod& rod, int s) {
  if (rod.segment_drive(s)) return Mat3::Zero();
  const Mat3 r = rod.orientations()[s].toRotationMatrix();
  const Vec3 in = rod.segment_inertia(s);
  for (const SegmentConstraint& c : rod.segment_constraints())
    if (c.segment == s) {
      const Vec3 b = r.transpose() * c.axis;
      return c.axis * c.axis.transpose() / b.dot(in.cwiseProduct(b));
    }
  return r * in.cwiseInverse().asDiagonal() * r.transpose();
}

}  // namespace

bool ContactSystem::needed(const World& world) {
  const bool obstacles = world.obstacles && world.obstacles->size() > 0;
  int rods = 0;
  for (const Rod& r : world.rods()) {
    const ContactOptions& o = r.contact_options();
    if (o.self || (obstacles && o.obstacles)) return true;
    if (o.rods) ++rods;
  }
  return rods >= 2;
}

void ContactSystem::solve(World& world, double h, ContactResponse& response) {
  const int nr = static_cast<int>(world.rods().size());
  velocity_.resize(nr);
  inv_mass_.resize(nr);
  omega_.resize(nr);
  spin_ = tracks_spin(world.contact);
  take_free_motion(world, h, response);
  detect(world, h, response);
  if (!response.lumped() && retake_closing(world, h, response)) {
    take_free_motion(world, h, response);
    detect(world, h, response);
  }
  if (!response.lumped()) detected_v_ = velocity_;
  warm_start();
  prepare_sweeps(world);
  if (response.lumped()) {
    sweep(world.contact, h, world.contact.iterations);
    finish(world, h, true);
  } else {
    const bool delassus =
        world.contact.implicit_solver == ContactSettings::Solver::kDelassus && !spin_;
    if (!delassus || !solve_delassus(world, h, response)) solve_rounds(world, h, response);
    // Between rods only (obstacles' contacts are not linearised again).
    bool pairs = false;
    for (const Rod& rod : world.rods())
      pairs = pairs || rod.contact_options().self || rod.contact_options().rods;
    for (int pass = 0; pairs && pass < world.contact.implicit_passes; ++pass) {
      // Detection again only adds pairs (the reach grows); a pass only where it did.
      const size_t detected = contacts_.size();
      if (outran_detection(world, h)) redetect(world, h);
      const bool relin = relinearise(world, h);
      if (!relin && contacts_.size() == detected) break;
      prepare_sweeps(world);
      solve_rounds(world, h, response);
    }
    finish(world, h, false);
  }
}

void ContactSystem::take_free_motion(const World& world, double h,
                                     const ContactResponse& response) {
  const auto& rods = world.rods();
  for (int r = 0; r < static_cast<int>(rods.size()); ++r)
    response.free_motion(rods[r], r, world.time(), h, spin_, &velocity_[r], &inv_mass_[r],
                         &omega_[r]);
}

// A BDF2 step carries a third of the last step's motion on whatever the impulses do: a rod
// meeting a contact the step would close (or a penetration) is stepped again as backward Euler,
// as the steps after it are while the contact lasts (the prediction), and detection redone.
// Other rods' BDF2 steps stand.
bool ContactSystem::retake_closing(World& world, double h, ContactResponse& response) {
  auto& rods = world.rods();
  const int nr = static_cast<int>(rods.size());
  bool retaken = false, any = false;
  for (int r = 0; r < nr; ++r) any = any || response.may_retake(r);
  for (size_t k = 0; any && k < contacts_.size(); ++k) {
    const Contact& c = contacts_[k];
    if (!response.may_retake(c.rod_a) && !(c.rod_b >= 0 && response.may_retake(c.rod_b))) continue;
    const Vec3 vr = relative_velocity(c, velocity_, true);
    if (vr.dot(c.normal) >= normal_target(c, world.contact, h)) continue;
    for (int r : {c.rod_a, c.rod_b}) {
      if (r < 0 || !response.may_retake(r)) continue;
      response.retake(rods[r], r, world.time(), h, world.gravity_at(world.time() + h));
      retaken = true;
    }
  }
  return retaken;
}

// The rounds hold d + h v_n linearised at the step's start; at the positions they leave, segments
// that slid over each other or turned can be closer than that (by up to a fifth of the radius at
// 1 m/s and 2 ms). Such a contact is linearised again at those positions (a Newton step on the
// distance): its closest points and normal there, and the offset that makes gap + h v_n - offset
// the distance there, so that the same targets now hold the true distance.
bool ContactSystem::relinearise(World& world, double h) {
  const auto& rods = world.rods();
  const double tolerance = world.contact.implicit_geometric_tolerance;
  bool any = false;
  for (Contact& c : contacts_) {
    if (c.rod_b < 0) continue;
    const auto& xa = rods[c.rod_a].positions();
    const auto& xb = rods[c.rod_b].positions();
    const auto& ya = *start_x_[c.rod_a];
    const auto& yb = *start_x_[c.rod_b];
    // The distance the pair keeps (the radii, or a neighbour's fold distance), as detected.
    const double keep = ((1.0 - c.s_a) * ya[c.seg_a] + c.s_a * ya[c.seg_a + 1] -
                         (1.0 - c.s_b) * yb[c.seg_b] - c.s_b * yb[c.seg_b + 1])
                            .norm() -
                        c.gap;
    const SegmentPair sp =
        closest_points(xa[c.seg_a], xa[c.seg_a + 1], xb[c.seg_b], xb[c.seg_b + 1]);
    const Vec3 d = (xa[c.seg_a] + sp.s * (xa[c.seg_a + 1] - xa[c.seg_a])) -
                   (xb[c.seg_b] + sp.t * (xb[c.seg_b + 1] - xb[c.seg_b]));
    const double dist = d.norm(), end_gap = dist - keep;
    if (!(end_gap < std::min(c.gap, 0.0) - tolerance * rods[c.rod_a].section().radius)) continue;
    if (!(d.dot(c.normal) > 0.0)) continue;  // the axes crossed: the start's normal stays
    c.s_a = sp.s;
    c.s_b = sp.t;
    c.normal = d / dist;
    const Vec3 vr =
        (1.0 - c.s_a) * velocity_[c.rod_a][c.seg_a] + c.s_a * velocity_[c.rod_a][c.seg_a + 1] -
        (1.0 - c.s_b) * velocity_[c.rod_b][c.seg_b] - c.s_b * velocity_[c.rod_b][c.seg_b + 1];
    c.offset = c.gap + h * vr.dot(c.normal) - end_gap;
    c.pt = within(tangential(c.pt, c.normal), c.mu * c.pn);
    any = true;
  }
  return any;
}

bool ContactSystem::outran_detection(const World& world, double h) const {
  const auto& rods = world.rods();
  const double skin = world.contact.skin;
  for (size_t r = 0; r < rods.size(); ++r) {
    if (!touched_[r]) continue;
    const double slack = skin * rods[r].section().radius / h;
    const auto& v0 = *start_v_[r];
    for (size_t i = 0; i < velocity_[r].size(); ++i)
      if (velocity_[r][i].norm() > std::max(detected_v_[r][i].norm(), v0[i].norm()) + slack)
        return true;
  }
  return false;
}

void ContactSystem::redetect(World& world, double h) {
  previous_.clear();
  for (const Contact& c : contacts_)
    if (c.pn > 0.0) previous_.push_back({pair_key(c), c.pn, c.pt, c.pr});
  std::sort(previous_.begin(), previous_.end(),
            [](const Previous& a, const Previous& b) { return a.key < b.key; });
  // Each node's reach from the larger of the speeds detection used and the solved ones.
  for (size_t r = 0; r < velocity_.size(); ++r)
    for (size_t i = 0; i < velocity_[r].size() && i < detected_v_[r].size(); ++i)
      if (detected_v_[r][i].norm() > velocity_[r][i].norm()) velocity_[r][i] = detected_v_[r][i];
  // Rod pairs only, and only added: the contacts found so far (the obstacles' with the bounds of
  // those with moving obstacles, the rod pairs with their relinearisation) stay as they are, and a
  // pair found again is dropped (redetecting them from the step's start undid the passes' work).
  const int kept = static_cast<int>(contacts_.size());
  detect_rod_pairs(world, h);
  which_.clear();
  for (int k = 0; k < static_cast<int>(contacts_.size()); ++k)
    if (contacts_[k].rod_b >= 0) which_.push_back(k);
  auto pair = [this](int k) {
    const Contact& c = contacts_[k];
    return std::make_tuple(c.rod_a, c.seg_a, c.rod_b, c.seg_b);
  };
  auto same_pair = [&](int i, int j) { return pair(i) == pair(j); };
  std::sort(which_.begin(), which_.end(),
            [&](int i, int j) { return std::make_pair(pair(i), i) < std::make_pair(pair(j), j); });
  for (size_t k = 1; k < which_.size(); ++k)
    if (which_[k] >= kept && same_pair(which_[k - 1], which_[k])) contacts_[which_[k]].rod_a = -1;
  contacts_.erase(std::remove_if(contacts_.begin() + kept, contacts_.end(),
                                 [](const Contact& c) { return c.rod_a < 0; }),
                  contacts_.end());
  stats_.contacts = static_cast<int>(contacts_.size());
  detected_v_ = velocity_;
  warm_start();
}

void ContactSystem::solve_rounds(World& world, double h, ContactResponse& response) {
  auto& rods = world.rods();
  const int nr = static_cast<int>(rods.size());
  held_v_.resize(nr);
  // Rounds: Gauss-Seidel sweeps against the rods' true velocities, with each node's own mass
  // (which responds more than the stiffness-coupled rod does, so they find too little impulse),
  // then the rods' true response to that change of the impulses, scaled by the factor that best
  // meets the normal constraints of the contacts carrying an impulse (a minimal-residual step:
  // one round is exact for a single contact), and projected back into the Coulomb cones. From the
  // second round on the step combines this change with the last round's (whose true response the
  // last round left): one scale alone zig-zags between rounds where many contacts load a rod
  // together. The last response sets the rods' state.
  const ContactSettings& cs = world.contact;
  const size_t nc = contacts_.size();
  // A rod whose step included predicted impulses is answered even without contacts now (the
  // response then takes the prediction back out).
  mark_touched(world, response);
  impulse_.resize(nr);
  change_v_.resize(nr);
  torque_.resize(nr);
  // With spin_, torque impulses too (surface friction's levers, rolling resistance).
  auto gather = [&](auto&& impulse_of, auto&& roll_of) {
    for (int r = 0; r < nr; ++r)
      if (touched_[r]) {
        impulse_[r].assign(rods[r].num_nodes(), Vec3::Zero());
        if (spin_) torque_[r].assign(rods[r].num_segments(), Vec3::Zero());
      }
    for (size_t k = 0; k < nc; ++k) {
      const Contact& c = contacts_[k];
      const Vec3 p = impulse_of(k);
      if (spin_) gather_torques(k, p);
      if (c.roll > 0.0) {
        const Vec3 pr = roll_of(k);
        torque_[c.rod_a][c.seg_a] += pr;
        if (c.rod_b >= 0) torque_[c.rod_b][c.seg_b] -= pr;
      }
      impulse_[c.rod_a][c.seg_a] += (1.0 - c.s_a) * p;
      impulse_[c.rod_a][c.seg_a + 1] += c.s_a * p;
      if (c.rod_b >= 0) {
        impulse_[c.rod_b][c.seg_b] -= (1.0 - c.s_b) * p;
        impulse_[c.rod_b][c.seg_b + 1] -= c.s_b * p;
      }
    }
  };
  auto respond_all = [&] {
    gather([&](size_t k) { return Vec3(contacts_[k].pn * contacts_[k].normal + contacts_[k].pt); },
           [&](size_t k) { return contacts_[k].pr; });
    for (int r = 0; r < nr; ++r) {
      if (!touched_[r]) continue;
      response.respond(rods[r], r, impulse_[r], spin_ ? &torque_[r] : nullptr);
      velocity_[r] = rods[r].velocities();
      if (spin_) take_angular_velocities(rods[r], r);
    }
  };
  respond_all();
  old_.resize(nc);
  last_dp_.resize(nc);
  last_dv_.resize(nr);
  for (int r = 0; r < nr; ++r)
    if (touched_[r]) last_dv_[r].resize(rods[r].num_nodes());
  stats_.iterations = 0;
  // How far the true velocities leave a contact closing past its target over the step, in units
  // of the rod's radius.
  auto violation = [&] {
    double worst = 0.0;
    for (const Contact& c : contacts_) {
      const Vec3 vr = relative_velocity(c, velocity_, true);
      const double closing = normal_target(c, cs, h) - vr.dot(c.normal);
      worst = std::max(worst, h * closing / rods[c.rod_a].section().radius);
    }
    return worst;
  };
  // With the warm-started impulses.
  const double tolerance = coupled_tolerance(world, h);
  for (int round = 0; round < cs.implicit_rounds && nc > 0; ++round) {
    if (round > 0 && violation() <= tolerance) break;
    ++stats_.rounds;
    for (size_t k = 0; k < nc; ++k)
      old_[k] = {0, contacts_[k].pn, contacts_[k].pt, contacts_[k].pr};
    for (int r = 0; r < nr; ++r)
      if (touched_[r]) held_v_[r] = velocity_[r];  // the true velocities
    sweep(cs, h, cs.implicit_sweeps);
    double change = 0.0, largest = 0.0;
    for (size_t k = 0; k < nc; ++k) {
      const Contact& c = contacts_[k];
      change =
          std::max(change, (c.pn * c.normal + c.pt - old_[k].pn * c.normal - old_[k].pt).norm());
      // Rolling resistance's change on the scale of the normal impulse (its bound is roll x pn).
      if (c.roll > 0.0) change = std::max(change, (c.pr - old_[k].pr).norm() / c.roll);
      largest = std::max(largest, c.pn);
    }
    if (change <= 1e-6 * largest) {
      for (int r = 0; r < nr; ++r)
        if (touched_[r]) velocity_[r] = held_v_[r];
      break;
    }
    gather(
        [&](size_t k) {
          const Contact& c = contacts_[k];
          return Vec3((c.pn - old_[k].pn) * c.normal + c.pt - old_[k].pt);
        },
        [&](size_t k) { return Vec3(contacts_[k].pr - old_[k].pr); });
    for (int r = 0; r < nr; ++r)
      if (touched_[r])
        response.response(rods[r], r, impulse_[r], &change_v_[r], spin_ ? &torque_[r] : nullptr);
    const bool use_last = round > 0;
    double num = 0.0, den = 0.0, num2 = 0.0, den2 = 0.0, cross = 0.0;
    for (const Contact& c : contacts_) {
      if (c.pn <= 0.0) continue;
      const Vec3 vr = relative_velocity(c, held_v_, true);
      const Vec3 dv = relative_velocity(c, change_v_, false);
      const Vec3 dl = use_last ? relative_velocity(c, last_dv_, false) : Vec3::Zero();
      const double res = vr.dot(c.normal) - normal_target(c, cs, h), dres = dv.dot(c.normal);
      const double dres2 = dl.dot(c.normal);
      num += res * dres;
      den += dres * dres;
      num2 += res * dres2;
      den2 += dres2 * dres2;
      cross += dres * dres2;
    }
    // With the last round's change as a second direction, the pair's best combination (unless
    // the two responses are nearly parallel); the last change's weight is bounded as this one's.
    double alpha = den > 0.0 ? std::clamp(-num / den, 1.0, cs.max_round_scale) : 1.0;
    double beta = 0.0;
    const double det = den * den2 - cross * cross;
    if (use_last && det > 1e-9 * den * den2) {
      alpha = std::clamp((num2 * cross - num * den2) / det, 1.0, cs.max_round_scale);
      beta = std::clamp(-(num2 + alpha * cross) / den2, -cs.max_round_scale, cs.max_round_scale);
    }
    for (size_t k = 0; k < nc; ++k) {
      Contact& c = contacts_[k];
      const double dpn = use_last ? last_dp_[k].pn : 0.0;
      const Vec3 dpt = use_last ? last_dp_[k].pt : Vec3::Zero();
      c.pn = std::max(0.0, old_[k].pn + alpha * (c.pn - old_[k].pn) + beta * dpn);
      if (any_cap_) c.pn = std::min(c.pn, cap_[k]);
      c.pt = within(tangential(old_[k].pt + alpha * (c.pt - old_[k].pt) + beta * dpt, c.normal),
                    c.mu * c.pn);
      // Rolling resistance as swept (the scale fits the normal rows), within the new bound.
      if (c.roll > 0.0) c.pr = within(c.pr, c.roll * c.pn);
      last_dp_[k] = {0, c.pn - old_[k].pn, c.pt - old_[k].pt, c.pr - old_[k].pr};
    }
    respond_all();
    // The true response to the change just made (clamps and cones included).
    for (int r = 0; r < nr; ++r)
      if (touched_[r])
        for (size_t i = 0; i < velocity_[r].size(); ++i)
          last_dv_[r][i] = velocity_[r][i] - held_v_[r][i];
  }
  remember_impulses(nr);  // as the next step's prediction
}

double ContactSystem::coupled_tolerance(const World& world, double h) const {
  const auto& rods = world.rods();
  const ContactSettings& cs = world.contact;
  double motion = 0.0;
  for (size_t r = 0; r < rods.size(); ++r)
    if (touched_[r])
      for (const Vec3& v : velocity_[r])
        motion = std::max(motion, h * v.norm() / rods[r].section().radius);
  return std::clamp(0.01 * motion, std::min(cs.implicit_tolerance_min, cs.implicit_tolerance),
                    cs.implicit_tolerance);
}

double ContactSystem::normal_target(const Contact& c, const ContactSettings& cs, double h) {
  // d + h v_n >= 0 for a gap; a penetration must not deepen (push_out removes it, from the
  // positions: a separating speed here would stay in the rod as momentum and throw it off). A
  // contact with a moving obstacle (a link pressing into the cable, a pinch) is pushed out at a
  // capped separating speed relative to its surface here instead (within max_dv where bounded).
  // A contact linearised again within the step (relinearise) opens by its offset besides.
  if (c.gap >= 0.0) return (c.offset - c.gap) / h;
  return c.moving || c.max_dv < kNoCap ? std::min(-cs.push_out * c.gap / h, cs.max_push_speed)
                                       : c.offset / h;
}

void ContactSystem::push_out(World& world, double h) {
  const ContactSettings& cs = world.contact;
  auto& rods = world.rods();
  const size_t nc = contacts_.size();
  const int nr = static_cast<int>(rods.size());
  auto point = [&](int r, int seg, double s, auto&& of) {
    return Vec3((1.0 - s) * of(r)[seg] + s * of(r)[seg + 1]);
  };
  auto velocities = [&](int r) -> const std::vector<Vec3>& { return rods[r].velocities(); };
  // Each contact's depth at the step's end (linearised from its gap at the start), the part of it
  // to remove now.
  push_target_.resize(nc);
  push_.assign(nc, 0.0);
  bool any = false;
  for (size_t k = 0; k < nc; ++k) {
    const Contact& c = contacts_[k];
    push_target_[k] = -kNoCap;                                              // no bound
    if (!(scratch_w_[k] > 0.0) || c.moving || c.max_dv < kNoCap) continue;  // in solve()
    Vec3 vr = point(c.rod_a, c.seg_a, c.s_a, velocities);
    vr -= c.rod_b >= 0 ? point(c.rod_b, c.seg_b, c.s_b, velocities) : c.surface_velocity;
    // A resting contact's overlap below a thousandth of the radius stays: moving it every step
    // would keep a still rope from settling (and the implicit step from skipping Newton).
    const double slop = 1e-3 * rods[c.rod_a].section().radius;
    const double end_gap = c.gap - c.offset + h * vr.dot(c.normal);
    const double depth = -end_gap - slop;
    // The others hold: no shift closes them past zero (or deepens a resting overlap).
    if (!(depth > 0.0)) {
      push_target_[k] = -std::max(end_gap, 0.0);
      continue;
    }
    const double fraction =
        cs.push_out_time > 0.0 ? std::min(cs.push_out, h / cs.push_out_time) : cs.push_out;
    push_target_[k] = std::min(fraction * depth, cs.max_push_speed * h);
    any = true;
  }
  if (!any) return;
  shift_.resize(nr);
  for (int r = 0; r < nr; ++r) shift_[r].assign(rods[r].num_nodes(), Vec3::Zero());
  auto shifts = [&](int r) -> const std::vector<Vec3>& { return shift_[r]; };
  // Gauss-Seidel over the penetrating contacts: normal displacement impulses >= 0, each node
  // moving by its inverse mass times its share, until no impulse changes by more than a millionth
  // of the largest.
  for (int it = 0; it < cs.iterations; ++it) {
    double change = 0.0, largest = 0.0;
    for (size_t k = 0; k < nc; ++k) {
      if (push_target_[k] == -kNoCap) continue;
      const Contact& c = contacts_[k];
      Vec3 moved = point(c.rod_a, c.seg_a, c.s_a, shifts);
      if (c.rod_b >= 0) moved -= point(c.rod_b, c.seg_b, c.s_b, shifts);
      double p =
          std::max(0.0, push_[k] + (push_target_[k] - moved.dot(c.normal)) * scratch_inv_w_[k]);
      // No node moves by more than max_push_speed h for one contact (next to a held node the
      // point moves by s times its free node's shift; two surfaces pinching a rod ask for
      // opposite shifts).
      const auto& wn = inv_mass_[c.rod_a];
      double node_w = std::max((1.0 - c.s_a) * wn[c.seg_a], c.s_a * wn[c.seg_a + 1]);
      if (c.rod_b >= 0) {
        const auto& wm = inv_mass_[c.rod_b];
        node_w = std::max({node_w, (1.0 - c.s_b) * wm[c.seg_b], c.s_b * wm[c.seg_b + 1]});
      }
      if (node_w > 0.0) p = std::min(p, cs.max_push_speed * h / node_w);
      const Vec3 dp = (p - push_[k]) * c.normal;
      push_[k] = p;
      const auto& wa = inv_mass_[c.rod_a];
      shift_[c.rod_a][c.seg_a] += ((1.0 - c.s_a) * wa[c.seg_a]) * dp;
      shift_[c.rod_a][c.seg_a + 1] += (c.s_a * wa[c.seg_a + 1]) * dp;
      if (c.rod_b >= 0) {
        const auto& wb = inv_mass_[c.rod_b];
        shift_[c.rod_b][c.seg_b] -= ((1.0 - c.s_b) * wb[c.seg_b]) * dp;
        shift_[c.rod_b][c.seg_b + 1] -= (c.s_b * wb[c.seg_b + 1]) * dp;
      }
      change = std::max(change, dp.norm());
      largest = std::max(largest, p);
    }
    if (change <= 1e-6 * largest) break;
  }
  // Held nodes have no inverse mass; a node on a line or plane moves along it only.
  for (int r = 0; r < nr; ++r) {
    Rod& rod = rods[r];
    for (const NodeConstraint& nc2 : rod.node_constraints()) {
      Vec3& d = shift_[r][nc2.node];
      d = nc2.kind == NodeConstraint::Kind::kLine ? Vec3(nc2.direction * nc2.direction.dot(d))
                                                  : tangential(d, nc2.direction);
    }
    auto& x = rod.positions();
    for (int i = 0; i < rod.num_nodes(); ++i) x[i] += shift_[r][i];
  }
}

void ContactSystem::prepare_sweeps(const World& world) {
  std::vector<double>& wsum = scratch_w_;
  wsum.resize(contacts_.size());
  scratch_inv_w_.resize(contacts_.size());
  if (any_cap_) cap_.resize(contacts_.size());
  levers_.clear();
  contact_levers_.resize(contacts_.size());
  if (world.contact.rolling_friction > 0.0) rolls_.resize(contacts_.size());
  for (size_t k = 0; k < contacts_.size(); ++k) {
    Contact& c = contacts_[k];
    const auto& wa = inv_mass_[c.rod_a];
    double w = (1 - c.s_a) * (1 - c.s_a) * wa[c.seg_a] + c.s_a * c.s_a * wa[c.seg_a + 1];
    if (c.rod_b >= 0) {
      const auto& wb = inv_mass_[c.rod_b];
      w += (1 - c.s_b) * (1 - c.s_b) * wb[c.seg_b] + c.s_b * c.s_b * wb[c.seg_b + 1];
    }
    wsum[k] = w;
    scratch_inv_w_[k] = w > 0.0 ? 1.0 / w : 0.0;
    if (any_cap_) {
      // The cap bounds each node's velocity change, not only the contact point's: next to a held
      // node the point moves by s times its free node's change, so a cap on the point alone would
      // let that node take max_dv / s. (Capped contacts are with obstacles: no rod b.)
      const double node_w = std::max((1 - c.s_a) * wa[c.seg_a], c.s_a * wa[c.seg_a + 1]);
      cap_[k] = c.max_dv < kNoCap && node_w > 0.0 ? c.max_dv / node_w : kNoCap;
      c.pn = std::min(c.pn, cap_[k]);
    }
    contact_levers_[k].count = 0;
    if (w > 0.0 && (c.lever_a > 0.0 || c.lever_b > 0.0)) prepare_levers(world, k);
    if (w > 0.0) apply_impulse(k, c.pn * c.normal + c.pt);
    if (c.roll > 0.0) {
      prepare_roll(world, k);
      if (rolls_[k].active) apply_roll(k, c.pr);
    }
  }
}

void ContactSystem::prepare_roll(const World& world, size_t k) {
  const Contact& c = contacts_[k];
  RollRow& rr = rolls_[k];
  rr.wa = segment_inverse_inertia(world.rods()[c.rod_a], c.seg_a);
  rr.wb = c.rod_b >= 0 ? segment_inverse_inertia(world.rods()[c.rod_b], c.seg_b) : Mat3::Zero();
  rr.t1 = any_perpendicular(c.normal);
  rr.t2 = c.normal.cross(rr.t1);
  const Eigen::Matrix2d kr = tangent_block(rr.wa + rr.wb, rr.t1, rr.t2);
  const double tr = kr.trace();
  rr.active = tr > 0.0;
  // A segment held to turn about one axis leaves the block singular: a small regularisation
  // answers only along the directions it can turn.
  if (rr.active) rr.inv_k = (kr + 1e-9 * tr * Eigen::Matrix2d::Identity()).inverse();
}

void ContactSystem::apply_roll(size_t k, const Vec3& dt) {
  const Contact& c = contacts_[k];
  const RollRow& rr = rolls_[k];
  omega_[c.rod_a][c.seg_a] += rr.wa * dt;
  if (c.rod_b >= 0) omega_[c.rod_b][c.seg_b] -= rr.wb * dt;
}

void ContactSystem::sweep_roll(size_t k) {
  Contact& c = contacts_[k];
  const RollRow& rr = rolls_[k];
  if (!rr.active) return;
  const Vec3 wr =
      omega_[c.rod_a][c.seg_a] - (c.rod_b >= 0 ? omega_[c.rod_b][c.seg_b] : c.surface_spin);
  // The torque that stops the relative rolling, projected onto the disc of radius roll x pn.
  const Eigen::Vector2d d = rr.inv_k * Eigen::Vector2d(rr.t1.dot(wr), rr.t2.dot(wr));
  const Vec3 pr = within(c.pr - d.x() * rr.t1 - d.y() * rr.t2, c.roll * c.pn);
  apply_roll(k, pr - c.pr);
  c.pr = pr;
}

// The segments that turn with contact k's point, and the pair's tangential inverse mass with their
// rotation: an impulse P at lever L turns a segment by J (L x P) and moves the point by that
// times L, so the inverse mass gains [L]x^T J [L]x; the normal row does not (L is along n).
void ContactSystem::prepare_levers(const World& world, size_t k) {
  const Contact& c = contacts_[k];
  ContactLevers& cl = contact_levers_[k];
  cl.first = static_cast<int>(levers_.size());
  auto add_side = [&](int r, int seg, double s, double lever) {
    if (!(lever > 0.0)) return;
    const Rod& rod = world.rods()[r];
    // A point at a node turns with both segments there, each taking half its torque.
    const int other = s <= 0.0 && seg > 0                        ? seg - 1
                      : s >= 1.0 && seg + 1 < rod.num_segments() ? seg + 1
                                                                 : -1;
    const double share = other >= 0 ? 0.5 : 1.0;
    for (int q : {seg, other})
      if (q >= 0) levers_.push_back({r, q, -share * lever, segment_inverse_inertia(rod, q)});
  };
  add_side(c.rod_a, c.seg_a, c.s_a, c.lever_a);
  if (c.rod_b >= 0) add_side(c.rod_b, c.seg_b, c.s_b, c.lever_b);
  cl.count = static_cast<int>(levers_.size()) - cl.first;
  const Mat3 nx = so3::skew(c.normal);
  Mat3 k3 = scratch_w_[k] * Mat3::Identity();
  for (int i = cl.first; i < cl.first + cl.count; ++i) {
    const Lever& l = levers_[i];
    k3 -= (l.c * l.c) * (nx * l.inv_inertia * nx);
  }
  cl.t1 = any_perpendicular(c.normal);
  cl.t2 = c.normal.cross(cl.t1);
  cl.inv_k = tangent_block(k3, cl.t1, cl.t2).inverse();  // >= w I, w > 0
}

Vec3 ContactSystem::lever_velocity(size_t k) const {
  const ContactLevers& cl = contact_levers_[k];
  Vec3 w = Vec3::Zero();
  for (int i = cl.first; i < cl.first + cl.count; ++i)
    w += levers_[i].c * omega_[levers_[i].rod][levers_[i].seg];
  return w.cross(contacts_[k].normal);
}

void ContactSystem::take_angular_velocities(const Rod& rod, int r) {
  const int ns = rod.num_segments();
  auto& om = omega_[r];
  om.resize(ns);
  for (int s = 0; s < ns; ++s) om[s] = rod.orientations()[s] * rod.angular_velocities()[s];
}

void ContactSystem::gather_torques(size_t k, const Vec3& p) {
  const ContactLevers& cl = contact_levers_[k];
  if (cl.count == 0) return;
  const Vec3 np = contacts_[k].normal.cross(p);
  for (int i = cl.first; i < cl.first + cl.count; ++i)
    torque_[levers_[i].rod][levers_[i].seg] += levers_[i].c * np;
}

void ContactSystem::apply_impulse(size_t k, const Vec3& p) {
  const Contact& c = contacts_[k];
  velocity_[c.rod_a][c.seg_a] += ((1.0 - c.s_a) * inv_mass_[c.rod_a][c.seg_a]) * p;
  velocity_[c.rod_a][c.seg_a + 1] += (c.s_a * inv_mass_[c.rod_a][c.seg_a + 1]) * p;
  if (c.rod_b >= 0) {
    velocity_[c.rod_b][c.seg_b] -= ((1.0 - c.s_b) * inv_mass_[c.rod_b][c.seg_b]) * p;
    velocity_[c.rod_b][c.seg_b + 1] -= (c.s_b * inv_mass_[c.rod_b][c.seg_b + 1]) * p;
  }
  const ContactLevers& cl = contact_levers_[k];
  if (cl.count == 0) return;
  const Vec3 np = c.normal.cross(p);  // the torque of p at a unit lever along -n
  for (int i = cl.first; i < cl.first + cl.count; ++i) {
    const Lever& l = levers_[i];
    omega_[l.rod][l.seg] += l.c * (l.inv_inertia * np);
  }
}

void ContactSystem::sweep(const ContactSettings& cs, double h, int iterations) {
  const std::vector<double>& wsum = scratch_w_;
  const std::vector<double>& inv_w = scratch_inv_w_;  // multiplications instead of divisions
  const bool capped = any_cap_;
  const bool levers = !levers_.empty();  // some contact turns segments (surface friction)
  const size_t nc = contacts_.size();
  // Sweeps until no impulse changes by more than a millionth of the largest (resting contacts,
  // warm started, settle in a few sweeps), or the iteration limit. The contact's nodes are read
  // and written in place (apply_impulse's arithmetic, inlined: this loop is the solve's hot one).
  for (int it = 0; it < iterations; ++it) {
    double change2 = 0.0, largest = 0.0;  // the largest change squared
    ++stats_.iterations;
    for (size_t k = 0; k < nc; ++k) {
      Contact& c = contacts_[k];
      const double w = wsum[k];
      if (!(w > 0.0)) continue;
      const double iw = inv_w[k];
      Vec3* va = velocity_[c.rod_a].data() + c.seg_a;
      const double* ma = inv_mass_[c.rod_a].data() + c.seg_a;
      Vec3* vb = c.rod_b >= 0 ? velocity_[c.rod_b].data() + c.seg_b : nullptr;
      // Relative to the other surface: a rod's, or a (moving) obstacle's; at the surfaces' common
      // point with surface friction (the segments' rotation adds a tangential part).
      const bool turns = levers && contact_levers_[k].count > 0;
      Vec3 vr = (1.0 - c.s_a) * va[0] + c.s_a * va[1];
      if (vb)
        vr -= (1.0 - c.s_b) * vb[0] + c.s_b * vb[1];
      else
        vr -= c.surface_velocity;
      if (turns) vr += lever_velocity(k);
      const double target = normal_target(c, cs, h);
      const Vec3& n = c.normal;
      const double vn = vr.dot(n);
      double pn = std::max(0.0, c.pn + (target - vn) * iw);
      if (capped) pn = std::min(pn, cap_[k]);
      Vec3 dp = (pn - c.pn) * n;
      c.pn = pn;
      // Friction: the impulse that stops the sliding, projected onto the Coulomb disc. Without
      // levers an impulse P changes the relative velocity by w P (a scalar inverse mass); with
      // them the tangential block is 2x2, solved exactly (the normal impulse turns nothing).
      const Vec3 after = vr + w * dp;
      const Vec3 vt = after - n * n.dot(after);
      Vec3 pt;
      if (!turns) {
        pt = c.pt - vt * iw;
      } else {
        const ContactLevers& cl = contact_levers_[k];
        const Eigen::Vector2d d = cl.inv_k * Eigen::Vector2d(cl.t1.dot(vt), cl.t2.dot(vt));
        pt = c.pt - d.x() * cl.t1 - d.y() * cl.t2;
      }
      pt = within(pt, c.mu * c.pn);
      dp += pt - c.pt;
      c.pt = pt;
      if (!turns) {
        va[0] += ((1.0 - c.s_a) * ma[0]) * dp;
        va[1] += (c.s_a * ma[1]) * dp;
        if (vb) {
          const double* mb = inv_mass_[c.rod_b].data() + c.seg_b;
          vb[0] -= ((1.0 - c.s_b) * mb[0]) * dp;
          vb[1] -= (c.s_b * mb[1]) * dp;
        }
      } else {
        apply_impulse(k, dp);
      }
      if (c.roll > 0.0) sweep_roll(k);
      change2 = std::max(change2, dp.squaredNorm());
      largest = std::max(largest, c.pn);
    }
    if (change2 <= 1e-12 * largest * largest) break;
  }
}

// The impulses as forces of the step (explicit: added to the rods' node forces); remembered for
// the next step's warm start.
void ContactSystem::finish(World& world, double h, bool add_forces) {
  auto& rods = world.rods();
  previous_.clear();
  stats_.active = 0;
  for (size_t k = 0; k < contacts_.size(); ++k) {
    const Contact& c = contacts_[k];
    if (c.pn <= 0.0) continue;
    ++stats_.active;
    previous_.push_back({pair_key(c), c.pn, c.pt, c.pr});
    if (!add_forces) continue;
    const Vec3 f = (c.pn * c.normal + c.pt) / h;
    rods[c.rod_a].add_step_force(c.seg_a, (1.0 - c.s_a) * f);
    rods[c.rod_a].add_step_force(c.seg_a + 1, c.s_a * f);
    if (c.rod_b >= 0) {
      rods[c.rod_b].add_step_force(c.seg_b, -(1.0 - c.s_b) * f);
      rods[c.rod_b].add_step_force(c.seg_b + 1, -c.s_b * f);
    }
    // Friction's moment about the axes (surface friction).
    const ContactLevers& cl = contact_levers_[k];
    const Vec3 nf = c.normal.cross(f);
    for (int i = cl.first; i < cl.first + cl.count; ++i)
      rods[levers_[i].rod].add_step_torque(levers_[i].seg, levers_[i].c * nf);
    if (c.roll > 0.0) {  // rolling resistance's couple
      rods[c.rod_a].add_step_torque(c.seg_a, c.pr / h);
      if (c.rod_b >= 0) rods[c.rod_b].add_step_torque(c.seg_b, -c.pr / h);
    }
  }
  std::sort(previous_.begin(), previous_.end(),
            [](const Previous& a, const Previous& b) { return a.key < b.key; });
}

void ContactSystem::warm_start() {
  for (Contact& c : contacts_) {
    c.pn = 0.0;
    c.pt.setZero();
    c.pr.setZero();
    const std::uint64_t key = pair_key(c);
    auto it = std::lower_bound(previous_.begin(), previous_.end(), key,
                               [](const Previous& p, std::uint64_t k) { return p.key < k; });
    if (it == previous_.end() || it->key != key) continue;
    c.pn = it->pn;
    c.pt = within(tangential(it->pt, c.normal), c.mu * c.pn);
    if (c.roll > 0.0) c.pr = within(tangential(it->pr, c.normal), c.roll * c.pn);
  }
}

void ContactSystem::detect(World& world, double h, const ContactResponse& response) {
  contacts_.clear();
  stats_ = ContactStats();
  auto& rods = world.rods();
  start_x_.resize(rods.size());
  start_v_.resize(rods.size());
  for (int r = 0; r < static_cast<int>(rods.size()); ++r) {
    start_x_[r] = &response.start_positions(rods[r], r);
    start_v_[r] = &response.start_velocities(rods[r], r);
  }
  const ContactSettings& cs = world.contact;
  if (world.obstacles && world.obstacles->size() > 0) {
    const ObstacleSet& obs = *world.obstacles;
    for (int r = 0; r < static_cast<int>(rods.size()); ++r) {
      const Rod& rod = rods[r];
      if (!rod.contact_options().obstacles) continue;
      const double radius = rod.section().radius;
      const auto& x = *start_x_[r];
      const auto& v = velocity_[r];
      const auto& v0 = *start_v_[r];
      const int n = rod.num_segments();
      // Each node as a point, and each segment at its closest interior point: a segment that
      // turns within the step can bring either end down, so one point per segment is not enough.
      for (int item = 0; item <= 2 * n; ++item) {
        const bool node = item <= n;
        const int s = node ? std::min(item, n - 1) : item - n - 1;
        const int i0 = node ? item : s, i1 = node ? item : s + 1;
        // How far the point or segment can travel in the step, plus a skin (the query adds what
        // a moving obstacle's surface can travel).
        const double speed = std::max({v[i0].norm(), v[i1].norm(), v0[i0].norm(), v0[i1].norm()});
        const double reach = radius * (1.0 + cs.skin) + h * speed;
        found_.clear();
        which_.clear();
        obs.query(x[i0], x[i1], reach, &found_, &which_, h);
        for (size_t k = 0; k < found_.size(); ++k) {
          const SegmentContact& f = found_[k];
          if (!node && (f.s <= 1e-9 || f.s >= 1.0 - 1e-9)) continue;  // a node's contact
          Contact c;
          c.rod_a = r;
          c.seg_a = s;
          c.s_a = node ? (item == n ? 1.0 : 0.0) : f.s;
          c.obstacle = which_[k];
          c.normal = f.normal;
          c.point = f.on_obstacle;
          c.gap = f.distance - radius;
          if (cs.surface_friction) c.lever_a = radius;  // at the rod's surface
          const Obstacle& ob = obs.obstacle(which_[k]);
          c.mu = ob.friction;
          c.surface_velocity = ob.velocity_at(f.on_obstacle);
          c.surface_spin = ob.angular_velocity;
          c.moving = ob.moving;
          c.roll = cs.rolling_friction * radius;
          contacts_.push_back(c);
        }
      }
    }
  }
  detect_rod_pairs(world, h);
  stats_.contacts = static_cast<int>(contacts_.size());
  const ObstacleSet* obs = world.obstacles.get();
  for (size_t k = 0; k < contacts_.size(); ++k) {
    Contact& c = contacts_[k];
    if (!(-c.gap > stats_.max_penetration)) continue;
    stats_.max_penetration = -c.gap;
    stats_.deepest = static_cast<int>(k);
  }
  any_cap_ = false;
  // A bounded contact with a moving obstacle: its normal impulse may change a node's velocity
  // relative to the surface by no more than stopping its approach and separating at
  // max_push_speed.
  auto bound_by_approach = [&](Contact& c) {
    const Vec3 vr = (1.0 - c.s_a) * velocity_[c.rod_a][c.seg_a] +
                    c.s_a * velocity_[c.rod_a][c.seg_a + 1] - c.surface_velocity;
    c.max_dv = std::max(0.0, -vr.dot(c.normal)) + cs.max_push_speed;
    any_cap_ = true;
  };
  // A moving obstacle against a segment with one held (driven) node: the contact point moves only
  // by the free node's share, so stopping the obstacle's approach there can need many times its
  // speed at that node (a link sweeping through the segment next to a gripper launched the cable).
  // Bound the node's velocity change as for deep contacts below.
  for (Contact& c : contacts_) {
    if (c.rod_b >= 0 || !obs->obstacle(c.obstacle).moving) continue;
    const Rod& rod = rods[c.rod_a];
    if (!rod.node_drive(c.seg_a) == !rod.node_drive(c.seg_a + 1)) continue;  // none or both held
    bound_by_approach(c);
  }
  // Deep contacts, searched only when the deepest contact can be one.
  double r_min = INFINITY;
  for (const Rod& rod : rods) r_min = std::min(r_min, rod.section().radius);
  if (!(stats_.max_penetration > cs.deep_penetration * r_min)) return;
  for (Contact& c : contacts_) {
    if (c.gap >= 0.0) continue;
    const double ratio = -c.gap / rods[c.rod_a].section().radius;
    if (!(ratio > cs.deep_penetration)) continue;
    stats_.max_ratio = std::max(stats_.max_ratio, ratio);
    // A deep contact with a moving obstacle (the obstacle made it) is bounded. Where two surfaces
    // closing on a rod demand opposite velocities (a pinch) their impulses would otherwise grow
    // without bound over the sweeps and launch the rod. Deep contacts the solver made (a fast
    // impact on a static obstacle, rods springing against each other) are not bounded: their
    // impulses are needed to stop the motion.
    if (c.rod_b >= 0 || !obs->obstacle(c.obstacle).moving) continue;
    bound_by_approach(c);
  }
}

namespace {

// What the pair list depends on besides positions: a rod's contact flags and its size.
std::uint64_t list_signature(const Rod& rod) {
  const ContactOptions& o = rod.contact_options();
  return static_cast<std::uint64_t>(rod.num_segments()) << 2 | (o.self ? 1u : 0u) |
         (o.rods ? 2u : 0u);
}

// Segments of a rod closer along it than this to segment s are its neighbours: their axes come
// closer than 2 r on a rod bent smoothly, so they are kept apart by fold_distance instead.
int neighbour_skip(const Rod& rod, int s) {
  return 1 + static_cast<int>(std::ceil(0.8 * M_PI * rod.section().radius / rod.rest_lengths()[s]));
}

// The closest the axes of segments sa and sb of one rod may come: on a rod bent no tighter than
// its radius r, points at arc distance L (the rest length between the segments' near nodes) are
// 2 r sin(L / 2r) apart, 2 r once L >= pi r; closer, the rod is folded through itself.
double fold_distance(const Rod& rod, int sa, int sb) {
  if (sa > sb) std::swap(sa, sb);
  const double r = rod.section().radius;
  double arc = 0.0;
  for (int k = sa + 1; k < sb; ++k) arc += rod.rest_lengths()[k];
  return 2.0 * r * std::sin(std::min(arc / (2.0 * r), 0.5 * M_PI));
}

}  // namespace

// Rod-rod and self contact. Each segment's box is grown by what it can travel in the step; the
// pairs whose boxes overlap go to the narrow phase in the order of a uniform grid no finer than the
// largest box (each box covers at most 8 cells, pairs are visited in the first cell both cover).
// The grid itself is only built now and then (build_pair_list): the pairs it finds with the boxes
// grown by a margin stay valid for the following steps until some segment has moved, or its box
// has grown, by more than that margin.
void ContactSystem::detect_rod_pairs(World& world, double h) {
  auto& rods = world.rods();
  const ContactSettings& cs = world.contact;
  const int nr = static_cast<int>(rods.size());
  int with_rods = 0;
  bool any_self = false;
  for (const Rod& r : rods) {
    with_rods += r.contact_options().rods;
    any_self = any_self || r.contact_options().self;
  }
  if (!any_self && with_rods < 2) return;
  items_.clear();
  boxes_.clear();
  grow_.clear();
  double cell = 0.0;
  for (int r = 0; r < nr; ++r) {
    const Rod& rod = rods[r];
    const ContactOptions& o = rod.contact_options();
    if (!o.self && !(o.rods && with_rods >= 2)) continue;
    const double radius = rod.section().radius;
    const auto& x = *start_x_[r];
    const auto& v = velocity_[r];
    for (int s = 0; s < rod.num_segments(); ++s) {
      const double grow = radius * (1.0 + cs.skin) + h * std::max(v[s].norm(), v[s + 1].norm());
      Eigen::AlignedBox3d box(x[s].cwiseMin(x[s + 1]), x[s].cwiseMax(x[s + 1]));
      box.min().array() -= grow;
      box.max().array() += grow;
      cell = std::max(cell, box.sizes().maxCoeff());
      items_.push_back({r, s});
      boxes_.push_back(box);
      grow_.push_back(grow);
    }
  }
  if (items_.size() < 2 || !(cell > 0.0) || !std::isfinite(cell)) return;
  if (!pair_list_valid(world)) build_pair_list(world);
  const double inv = 1.0 / cell;
  auto lo_cell = [&](const Eigen::AlignedBox3d& b) {
    return Eigen::Vector3d((b.min() * inv).array().floor());
  };
  // The listed pairs whose boxes overlap, sorted as the grid would visit them: by the first cell
  // both cover, then by item (the narrow phase's order is the Gauss-Seidel order of the solve).
  overlaps_.clear();
  for (const auto& [i, j] : pair_list_) {
    const Eigen::AlignedBox3d &bi = boxes_[i], &bj = boxes_[j];
    if (!bi.intersects(bj)) continue;
    const Vec3 first = lo_cell(bi).cwiseMax(lo_cell(bj));
    overlaps_.push_back(
        {cell_key(static_cast<std::int64_t>(first.x()), static_cast<std::int64_t>(first.y()),
                  static_cast<std::int64_t>(first.z())),
         i, j});
  }
  std::sort(overlaps_.begin(), overlaps_.end(), [](const Overlap& a, const Overlap& b) {
    return a.cell != b.cell ? a.cell < b.cell : a.i != b.i ? a.i < b.i : a.j < b.j;
  });
  for (const Overlap& o : overlaps_) {
    const auto [ra, sa] = items_[o.i];
    const auto [rb, sb] = items_[o.j];
    const Rod &rod_a = rods[ra], &rod_b = rods[rb];
    ++stats_.candidate_pairs;
    const auto& xa = *start_x_[ra];
    const auto& xb = *start_x_[rb];
    const SegmentPair sp = closest_points(xa[sa], xa[sa + 1], xb[sb], xb[sb + 1]);
    const double ra_ = rod_a.section().radius, rb_ = rod_b.section().radius;
    const Vec3 pa = xa[sa] + sp.s * (xa[sa + 1] - xa[sa]);
    const Vec3 pb = xb[sb] + sp.t * (xb[sb + 1] - xb[sb]);
    const Vec3 d = pa - pb;
    const double dist = d.norm();
    const auto& va = velocity_[ra];
    const auto& vb = velocity_[rb];
    // A neighbour along the rod is in contact only where the rod between them is folded; it moves
    // with the segment, so what their relative motion closes in the step bounds its approach.
    const bool near = ra == rb && std::abs(sa - sb) < std::max(list_skip_[o.i], list_skip_[o.j]);
    double closing = 0.0;
    if (near) {
      for (int p = sa; p <= sa + 1; ++p)
        for (int q = sb; q <= sb + 1; ++q) closing = std::max(closing, (va[p] - vb[q]).norm());
    } else {
      closing = va[sa].norm() + va[sa + 1].norm() + vb[sb].norm() + vb[sb + 1].norm();
    }
    const double gap = dist - (near ? fold_distance(rod_a, sa, sb) : ra_ + rb_);
    if (gap > cs.skin * (ra_ + rb_) + h * closing) continue;
    Contact c;
    c.rod_a = ra;
    c.seg_a = sa;
    c.s_a = sp.s;
    c.rod_b = rb;
    c.seg_b = sb;
    c.s_b = sp.t;
    c.normal = dist > 1e-12 * (ra_ + rb_) ? Vec3(d / dist) : any_perpendicular(xa[sa + 1] - xa[sa]);
    c.point = pb + rb_ * c.normal;
    c.gap = gap;
    if (cs.surface_friction) {  // one point for both sides, between the surfaces
      c.lever_a = dist * ra_ / (ra_ + rb_);
      c.lever_b = dist * rb_ / (ra_ + rb_);
    }
    const double ma =
        rod_a.contact_options().friction >= 0.0 ? rod_a.contact_options().friction : cs.friction;
    const double mb =
        rod_b.contact_options().friction >= 0.0 ? rod_b.contact_options().friction : cs.friction;
    c.mu = std::sqrt(ma * mb);
    c.roll = cs.rolling_friction * 2.0 * ra_ * rb_ / (ra_ + rb_);
    contacts_.push_back(c);
  }
}

// The list holds every pair whose boxes overlap now if each item's box lies inside its box at the
// build grown by the margin: its nodes moved by at most D per axis since, so that holds while
// D + grow now <= grow then + margin.
bool ContactSystem::pair_list_valid(const World& world) const {
  const auto& rods = world.rods();
  if (list_rods_.size() != rods.size() || list_grow_.size() != items_.size()) return false;
  for (size_t r = 0; r < rods.size(); ++r)
    if (list_signature(rods[r]) != list_rods_[r]) return false;
  for (size_t k = 0; k < items_.size(); ++k) {
    const auto [r, s] = items_[k];
    const auto& x = *start_x_[r];
    const auto& x0 = list_positions_[r];
    const double moved = std::max((x[s] - x0[s]).cwiseAbs().maxCoeff(),
                                  (x[s + 1] - x0[s + 1]).cwiseAbs().maxCoeff());
    if (!(moved + grow_[k] <= list_grow_[k] + list_margin_)) return false;
    if (neighbour_skip(rods[r], s) != list_skip_[k]) return false;
  }
  return true;
}

// The pairs of items whose boxes, grown by the margin (the largest radius), overlap: a uniform
// grid no finer than the largest grown box, so the cost is linear in the number of segments;
// pairs are tested once, in the first cell both cover. Neighbours along a rod, and pairs of rods
// that do not both take part in rod contact, are left out.
void ContactSystem::build_pair_list(const World& world) {
  const auto& rods = world.rods();
  list_margin_ = 0.0;
  for (const auto& [r, s] : items_) list_margin_ = std::max(list_margin_, rods[r].section().radius);
  list_rods_.resize(rods.size());
  list_positions_.resize(rods.size());
  for (size_t r = 0; r < rods.size(); ++r) {
    list_rods_[r] = list_signature(rods[r]);
    list_positions_[r] = *start_x_[r];
  }
  list_grow_ = grow_;
  list_skip_.resize(items_.size());
  for (size_t k = 0; k < items_.size(); ++k)
    list_skip_[k] = neighbour_skip(rods[items_[k].first], items_[k].second);
  pair_list_.clear();
  auto grown = [&](int k) {
    return Eigen::AlignedBox3d(boxes_[k].min().array() - list_margin_,
                               boxes_[k].max().array() + list_margin_);
  };
  double cell = 0.0;
  for (size_t k = 0; k < items_.size(); ++k)
    cell = std::max(cell, grown(static_cast<int>(k)).sizes().maxCoeff());
  const double inv = 1.0 / cell;
  auto lo_cell = [&](const Eigen::AlignedBox3d& b) {
    return Eigen::Vector3d((b.min() * inv).array().floor());
  };
  auto hi_cell = [&](const Eigen::AlignedBox3d& b) {
    return Eigen::Vector3d((b.max() * inv).array().floor());
  };
  cells_.clear();
  for (int i = 0; i < static_cast<int>(items_.size()); ++i) {
    const Eigen::AlignedBox3d b = grown(i);
    const Vec3 lo = lo_cell(b), hi = hi_cell(b);
    for (double cx = lo.x(); cx <= hi.x(); ++cx)
      for (double cy = lo.y(); cy <= hi.y(); ++cy)
        for (double cz = lo.z(); cz <= hi.z(); ++cz)
          cells_.push_back({cell_key(static_cast<std::int64_t>(cx), static_cast<std::int64_t>(cy),
                                     static_cast<std::int64_t>(cz)),
                            i});
  }
  std::sort(cells_.begin(), cells_.end(), [](const CellEntry& a, const CellEntry& b) {
    return a.cell != b.cell ? a.cell < b.cell : a.item < b.item;
  });
  for (size_t g0 = 0; g0 < cells_.size();) {
    size_t g1 = g0 + 1;
    while (g1 < cells_.size() && cells_[g1].cell == cells_[g0].cell) ++g1;
    for (size_t p = g0; p < g1; ++p)
      for (size_t q = p + 1; q < g1; ++q) {
        const int i = cells_[p].item, j = cells_[q].item;
        const Eigen::AlignedBox3d bi = grown(i), bj = grown(j);
        if (!bi.intersects(bj)) continue;
        const Vec3 first = lo_cell(bi).cwiseMax(lo_cell(bj));
        if (cell_key(static_cast<std::int64_t>(first.x()), static_cast<std::int64_t>(first.y()),
                     static_cast<std::int64_t>(first.z())) != cells_[p].cell)
          continue;
        const auto [ra, sa] = items_[i];
        const auto [rb, sb] = items_[j];
        const Rod &rod_a = rods[ra], &rod_b = rods[rb];
        if (ra == rb) {
          // Segments sharing a node touch by construction; nearer ones than list_skip_ are
          // listed too and meet only where the rod folds (fold_distance).
          if (!rod_a.contact_options().self || std::abs(sa - sb) <= 1) continue;
        } else if (!rod_a.contact_options().rods || !rod_b.contact_options().rods) {
          continue;
        }
        pair_list_.push_back({i, j});
      }
    g0 = g1;
  }
}

namespace {

// "4.2 mm (1.4 r) into 'upper'" or "... into rod 'b' segment 3".
std::string depth_phrase(const World& world, const Contact& c) {
  const double r = world.rods()[c.rod_a].section().radius;
  char buf[96];
  std::snprintf(buf, sizeof buf, "%.3g mm (%.3g r) into ", -c.gap * 1e3, -c.gap / r);
  std::string what;
  if (c.rod_b >= 0)
    what = "rod '" + world.rods()[c.rod_b].name() + "' segment " + std::to_string(c.seg_b);
  else if (world.obstacles && c.obstacle >= 0 && c.obstacle < world.obstacles->size())
    what = "'" + world.obstacles->obstacle(c.obstacle).name + "'";
  else
    what = "obstacle " + std::to_string(c.obstacle);
  return buf + what;
}

}  // namespace

std::string describe_contact(const World& world, const Contact& c) {
  return "segment " + std::to_string(c.seg_a) + ": " + depth_phrase(world, c);
}

std::string deep_contact_report(const World& world, double fraction, int max_lines) {
  const ContactSystem* cs = world.contacts();
  if (!cs || cs->stats().deepest < 0) return "";
  const auto& contacts = cs->contacts();
  std::vector<int> deep;
  for (size_t k = 0; k < contacts.size(); ++k) {
    const Contact& c = contacts[k];
    if (c.rod_a < static_cast<int>(world.rods().size()) &&
        -c.gap > fraction * world.rods()[c.rod_a].section().radius)
      deep.push_back(static_cast<int>(k));
  }
  std::stable_sort(deep.begin(), deep.end(),
                   [&](int a, int b) { return contacts[a].gap < contacts[b].gap; });
  // Per rod segment its deepest contact with each partner (a pinch: both links on one line).
  struct Line {
    int rod, seg;
    std::vector<std::pair<int, int>> partners;  // (rod_b, obstacle)
    std::string text;
  };
  std::vector<Line> lines;
  for (int k : deep) {
    const Contact& c = contacts[k];
    const std::pair<int, int> partner{c.rod_b, c.rod_b >= 0 ? c.seg_b : c.obstacle};
    auto it = std::find_if(lines.begin(), lines.end(),
                           [&](const Line& l) { return l.rod == c.rod_a && l.seg == c.seg_a; });
    if (it == lines.end()) {
      if (static_cast<int>(lines.size()) >= max_lines) continue;
      lines.push_back({c.rod_a,
                       c.seg_a,
                       {partner},
                       "rod '" + world.rods()[c.rod_a].name() + "' " + describe_contact(world, c)});
    } else if (std::find(it->partners.begin(), it->partners.end(), partner) == it->partners.end()) {
      it->partners.push_back(partner);
      it->text += ", " + depth_phrase(world, c);
    }
  }
  std::string out;
  for (const Line& l : lines) out += (out.empty() ? "" : "; ") + l.text;
  return out;
}

}  // namespace corde
