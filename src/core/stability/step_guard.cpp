#include "corde_sim/stability/step_guard.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>

#include "corde_sim/integrators/integrator_names.h"
#include "corde_sim/model/element_energies.h"
#include "corde_sim/model/loads.h"
#include "corde_sim/stability/explicit_step_limit.h"

namespace corde {
namespace {

constexpr Integrator kImplicit = Integrator::kImplicitEuler;

const char* method_name(Integrator i) { return integrator_name(i); }

GuardEvent::Kind guard_kind(StateCheck check) {
  switch (check) {
    case StateCheck::kNonFinite:
      return GuardEvent::Kind::kNonFinite;
    case StateCheck::kQuaternion:
      return GuardEvent::Kind::kQuaternion;
    case StateCheck::kSpeed:
      return GuardEvent::Kind::kSpeed;
    case StateCheck::kStretch:
      return GuardEvent::Kind::kStretch;
    case StateCheck::kShear:
      return GuardEvent::Kind::kShear;
    case StateCheck::kBend:
      return GuardEvent::Kind::kBend;
    case StateCheck::kSpecificEnergy:
      return GuardEvent::Kind::kSpecificEnergy;
    case StateCheck::kPenetration:
      return GuardEvent::Kind::kPenetration;
  }
  return GuardEvent::Kind::kNonFinite;
}

const char* action_text(GuardEvent::Action a) {
  switch (a) {
    case GuardEvent::Action::kHalveStep:
      return "retrying with half the step";
    case GuardEvent::Action::kImplicit:
      return "retrying with the implicit method";
    case GuardEvent::Action::kGiveUp:
      return "no retry left: the world stays at its last good state";
    case GuardEvent::Action::kRestore:
      return "trying the user's step and method again";
    case GuardEvent::Action::kNone:
      break;
  }
  return "";
}

}  // namespace

const char* guard_event_kind_name(GuardEvent::Kind kind) {
  switch (kind) {
    case GuardEvent::Kind::kNonFinite:
      return state_check_name(StateCheck::kNonFinite);
    case GuardEvent::Kind::kQuaternion:
      return state_check_name(StateCheck::kQuaternion);
    case GuardEvent::Kind::kSpeed:
      return state_check_name(StateCheck::kSpeed);
    case GuardEvent::Kind::kStretch:
      return state_check_name(StateCheck::kStretch);
    case GuardEvent::Kind::kShear:
      return state_check_name(StateCheck::kShear);
    case GuardEvent::Kind::kBend:
      return state_check_name(StateCheck::kBend);
    case GuardEvent::Kind::kSpecificEnergy:
      return state_check_name(StateCheck::kSpecificEnergy);
    case GuardEvent::Kind::kPenetration:
      return state_check_name(StateCheck::kPenetration);
    case GuardEvent::Kind::kEnergy:
      return "energy";
    case GuardEvent::Kind::kRestored:
      return "restored";
    case GuardEvent::Kind::kUnrecoverable:
      return "unrecoverable";
  }
  return "?";
}

std::string GuardEvent::message() const {
  char buf[160];
  std::snprintf(buf, sizeof buf, "t = %.6g s: ", time);
  std::string m = buf;
  if (kind == Kind::kRestored) {
    std::snprintf(buf, sizeof buf, "%s: time step %.3g s (%s)", action_text(action), time_step,
                  method_name(integrator));
    return m + buf;
  }
  m += guard_event_kind_name(kind);
  if (!rod.empty()) m += ", rod '" + rod + "'";
  m += ": " + detail;
  if (action == Action::kNone) return m;
  std::snprintf(buf, sizeof buf, "; rolled back to t = %.6g s, ", rollback_to);
  m += buf;
  m += action_text(action);
  if (action == Action::kHalveStep || action == Action::kImplicit) {
    std::snprintf(buf, sizeof buf, " (time step %.3g s, %s)", time_step, method_name(integrator));
    m += buf;
  }
  return m;
}

void StepGuard::reset(const World& world) {
  user_h_ = h_ = world.time_step;
  user_integrator_ = integrator_ = world.integrator;
  halvings_ = 0;
  failed_ = false;
  trial_ = false;
  relax_after_ = settings_.relax_after;
  good_since_ = world.time();
  detections_ = rollbacks_ = 0;
  kept_work_ = 0.0;
  mgl_ = 0.0;
  const double g = std::max(world.gravity.norm(), 1.0);
  for (const Rod& rod : world.rods()) {
    double m = 0.0, len = 0.0;
    for (double mi : rod.node_masses()) m += mi;
    for (double l : rod.rest_lengths()) len += l;
    mgl_ += m * g * len;
  }
  snapshot(world);
}

void StepGuard::sync_user_settings(const World& world) {
  if (world.time_step == user_h_ && world.integrator == user_integrator_) return;
  user_h_ = h_ = world.time_step;
  user_integrator_ = integrator_ = world.integrator;
  halvings_ = 0;
  trial_ = false;
}

void StepGuard::snapshot(const World& world, const WorldEnergies* energies) {
  world.copy_to(&snap_);
  have_snap_ = true;
  const WorldEnergies e = energies ? *energies : world.energies();
  snap_energy_ = e.kinetic() + e.elastic() + e.total.gravity;
  snap_scale_ = e.kinetic() + e.elastic();
  kept_work_ += work_;
  work_ = 0.0;
  since_snap_ = 0;
  since_check_ = 0;
  if (save_) save_();
}

void StepGuard::rollback(World* world) {
  snap_.copy_to(world);
  if (restore_) restore_();
  work_ = 0.0;
  since_snap_ = 0;
  since_check_ = 0;
  ++rollbacks_;
}

GuardProblem StepGuard::check(const World& world, WorldEnergies* energies) const {
  GuardProblem p;
  const StateProblem state = check_state(world, settings_.limits);
  if (state.found) {
    p.found = true;
    p.kind = guard_kind(state.check);
    p.rod = state.rod;
    p.item = state.item;
    p.detail = state.detail;
    return p;
  }
  const WorldEnergies e = world.energies();
  *energies = e;
  if (settings_.energy_tolerance <= 0.0) return p;
  const double rise = e.kinetic() + e.elastic() + e.total.gravity - snap_energy_;
  // The work is summed to first order (each step's reaction times the end-of-step velocity), so
  // the energy it brings in carries the integrator's relative error as the energy at the
  // snapshot does: the tolerance covers both.
  const double allowed = work_ + settings_.energy_tolerance * (snap_scale_ + work_) +
                         settings_.energy_floor * mgl_ + 1e-12;
  if (rise > allowed) {
    p.found = true;
    p.kind = GuardEvent::Kind::kEnergy;
    char buf[200];
    std::snprintf(buf, sizeof buf,
                  "the energy rose by %.3g J since the last check; work done at most %.3g J, "
                  "allowed %.3g J",
                  rise, work_, allowed);
    p.detail = buf;
    // Name the rod with the most kinetic and elastic energy per mass: the one running away.
    double worst = -1.0;
    for (const Rod& rod : world.rods()) {
      double m = 0.0;
      for (double mi : rod.node_masses()) m += mi;
      const Energies r = rod.energies(world.gravity_at(world.time()));
      const double specific = (r.kinetic() + r.elastic()) / m;
      if (specific > worst) {
        worst = specific;
        p.rod = rod.name();
      }
    }
  }
  return p;
}

// A bound on the work done on the rods over the last step of length h: sum of |power| h over
// every source that is not in the energy itself (gravity is; internal friction, drag and contact
// friction only take energy out).
void StepGuard::add_step_work(const World& world, double h) {
  double w = 0.0;
  const double t1 = world.time(), t0 = t1 - h;
  // Gravity ramping in (World::gravity_ramp) changes its potential at fixed positions.
  const bool ramp = world.gravity_ramp > 0.0 && t0 < world.gravity_ramp;
  const Vec3 dg = ramp ? Vec3(world.gravity_at(t1) - world.gravity_at(t0)) : Vec3::Zero();
  for (const Rod& rod : world.rods()) {
    const auto& v = rod.velocities();
    const auto& q = rod.orientations();
    if (ramp) {
      double du = 0.0;
      for (int i = 0; i < rod.num_nodes(); ++i)
        du += rod.node_masses()[i] * dg.dot(rod.positions()[i]);
      for (const Rod::MassOffset& m : rod.mass_offsets()) du -= m.potential(q[m.segment], dg);
      w += std::abs(du);
    }
    const auto& om = rod.angular_velocities();
    for (const NodeDrive& d : rod.node_drives()) w += std::abs(d.reaction.dot(v[d.node])) * h;
    for (const SegmentDrive& d : rod.segment_drives())
      w += std::abs(d.reaction.dot(q[d.segment] * om[d.segment])) * h;
    // A moving clamp's ghost frame works on its boundary element: the element's energy change
    // from the frame's turn over the step, the rod held at its end-of-step state (exact for a
    // large turn, where the torque times the turn is not; the torque, GhostFrame::reaction, is
    // recorded at a different point of the step by the explicit and the implicit methods).
    const int n = rod.num_segments();
    for (int end = 0; end < 2; ++end) {
      const GhostFrame& g = end == 0 ? rod.ghost_start() : rod.ghost_end();
      if (!g.active || !g.motion) continue;
      const Vec3 k(rod.section().bend, rod.section().bend, rod.section().twist);
      const int s = end == 0 ? 0 : n - 1;
      const double l = 0.5 * rod.rest_lengths()[s];
      const Quat g0 = ghost_frame_at(g, t0);  // g.frame is the frame at t1
      const double e1 = end == 0 ? bend_twist_energy(g.frame, q[s], l, k, g.uhat, nullptr, nullptr)
                                 : bend_twist_energy(q[s], g.frame, l, k, g.uhat, nullptr, nullptr);
      const double e0 = end == 0 ? bend_twist_energy(g0, q[s], l, k, g.uhat, nullptr, nullptr)
                                 : bend_twist_energy(q[s], g0, l, k, g.uhat, nullptr, nullptr);
      w += std::abs(e1 - e0);
    }
    for (const Load& l : rod.loads()) {
      const double f = load_magnitude(l, l.scale(t1));
      if (f == 0.0) continue;
      if (l.kind == Load::Kind::kForce)
        w += f * v[l.index].norm() * h;
      else
        w += f * om[l.index].norm() * h;
    }
    if (rod.has_external()) {
      const auto& ef = rod.external_forces();
      const auto& et = rod.external_torques();
      for (size_t i = 0; i < ef.size(); ++i) w += ef[i].norm() * v[i].norm() * h;
      for (size_t k = 0; k < et.size(); ++k) w += et[k].norm() * om[k].norm() * h;
    }
  }
  // Contacts: a moving obstacle's surface works on the rod (its rolling resistance too, if it
  // turns), and the push-out that removes a penetration moves the rod against the contact force
  // by at most that speed times h (ContactSystem::push_out).
  if (const ContactSystem* c = world.contacts()) {
    const ContactSettings& cs = world.contact;
    for (const Contact& k : c->contacts()) {
      if (k.pn == 0.0 && k.pt.isZero()) continue;
      const double push = std::min(cs.max_push_speed, cs.push_out * std::max(0.0, -k.gap) / h);
      w += (k.pn * k.normal + k.pt).norm() * (k.surface_velocity.norm() + push);
      w += k.pr.norm() * k.surface_spin.norm();  // rolling resistance on a turning obstacle
    }
  }
  work_ += w;
}

void StepGuard::push_event(const GuardEvent& e) {
  if (events_.size() >= 1000) events_.erase(events_.begin());
  events_.push_back(e);
  ++events_total_;
}

bool StepGuard::reduce(const World& world, const GuardProblem& p, double t_fail) {
  GuardEvent e;
  e.time = t_fail;
  e.kind = p.kind;
  e.rod = p.rod;
  e.item = p.item;
  e.detail = p.detail;
  e.rollback_to = world.time();
  const bool threw = p.detail.rfind("the step threw", 0) == 0;
  // bdf2 is implicit too: it halves its step, and the fallback stays implicit_euler.
  const bool explicit_method = has_explicit_step_limit(integrator_);
  const bool allow_implicit = settings_.allow_implicit;
  if (trial_) {
    // The user's setting failed again: back to the one that worked, and wait longer next time.
    trial_ = false;
    h_ = saved_h_;
    integrator_ = saved_integrator_;
    halvings_ = saved_halvings_;
    relax_after_ *= 2.0;
    e.action = integrator_ == kImplicit && explicit_method ? GuardEvent::Action::kImplicit
                                                           : GuardEvent::Action::kHalveStep;
  } else {
    bool halve = !threw && halvings_ < settings_.max_halvings;
    if (halve && explicit_method && allow_implicit) {
      // Halving cannot help when even the last allowed halving stays above the explicit limit,
      // linearised about the state the world went back to (a collapsed or crumpled rod's limit
      // can be far below its straight one's).
      const double limit = explicit_step_limit(world, true).time_step;
      if (user_h_ / std::ldexp(1.0, settings_.max_halvings) > limit) halve = false;
    }
    if (halve) {
      ++halvings_;
      h_ = user_h_ / std::ldexp(1.0, halvings_);
      e.action = GuardEvent::Action::kHalveStep;
    } else if (explicit_method && allow_implicit) {
      integrator_ = kImplicit;
      halvings_ = 0;
      h_ = user_h_;
      e.action = GuardEvent::Action::kImplicit;
    } else {
      e.action = GuardEvent::Action::kGiveUp;
    }
  }
  e.time_step = h_;
  e.integrator = integrator_;
  good_since_ = world.time();
  push_event(e);
  if (e.action != GuardEvent::Action::kGiveUp) return true;
  GuardEvent u = e;
  u.kind = GuardEvent::Kind::kUnrecoverable;
  push_event(u);
  return false;
}

bool StepGuard::step(World* world, long n, const StepFn& fn) {
  return advance(world, n, false, fn);
}

bool StepGuard::settle(World* world, const StepFn& fn) { return advance(world, 0, true, fn); }

bool StepGuard::advance(World* world, long n, bool check_at_end, const StepFn& fn) {
  if (!settings_.enabled) {
    for (long i = 0; i < n; ++i) fn ? fn(world) : world->step();
    return true;
  }
  if (!have_snap_) reset(*world);
  if (failed_) return false;
  sync_user_settings(*world);
  // The world runs the guard's setting inside and shows the user's outside.
  apply(world);
  const bool ok = run(world, n, check_at_end, fn);
  world->time_step = user_h_;
  world->integrator = user_integrator_;
  return ok;
}

bool StepGuard::run(World* world, long n, bool check_at_end, const StepFn& fn) {
  long goal = since_snap_ + n;  // user steps from the snapshot
  const int every = std::max(1, settings_.check_every);
  for (;;) {
    std::string threw, stalled;
    if (since_snap_ < goal) {
      const long sub = 1L << halvings_;
      for (long i = 0; i < sub && threw.empty() && stalled.empty(); ++i) {
        try {
          fn ? fn(world) : world->step();
        } catch (const std::exception& ex) {
          threw = ex.what();
        }
        // An implicit step whose Newton iterations stopped far short of their tolerance left the
        // rods at an iterate, not a solution: a failure that a smaller step can cure.
        if (is_implicit(world->integrator) && world->implicit_stats().unconverged > 0 &&
            !(world->implicit_stats().worst_residual <= 1e-3)) {
          char buf[160];
          std::snprintf(buf, sizeof buf,
                        "the implicit step did not converge (residual %.3g of its scale)",
                        world->implicit_stats().worst_residual);
          stalled = buf;
        }
        add_step_work(*world, h_);
        ++since_check_;
      }
      ++since_snap_;
      const bool due = !threw.empty() || !stalled.empty() || since_check_ >= every ||
                       (check_at_end && since_snap_ == goal);
      if (!due) continue;
    } else if (!check_at_end || since_check_ == 0) {
      return true;
    }
    GuardProblem p;
    WorldEnergies energies;
    if (!threw.empty()) {
      p.found = true;
      p.kind = GuardEvent::Kind::kNonFinite;
      p.detail = "the step threw: " + threw;
    } else if (!stalled.empty()) {
      p.found = true;
      p.kind = GuardEvent::Kind::kNonFinite;
      p.detail = stalled;
    } else {
      p = check(*world, &energies);
    }
    if (!p.found) {
      goal -= since_snap_;
      snapshot(*world, &energies);
      const double t = world->time();
      if (trial_ && t - good_since_ >= relax_after_) {
        trial_ = false;  // the user's setting holds again
        relax_after_ = settings_.relax_after;
      } else if (!trial_ && reduced() && t - good_since_ >= relax_after_) {
        saved_h_ = h_;
        saved_integrator_ = integrator_;
        saved_halvings_ = halvings_;
        h_ = user_h_;
        integrator_ = user_integrator_;
        halvings_ = 0;
        trial_ = true;
        good_since_ = t;
        GuardEvent e;
        e.kind = GuardEvent::Kind::kRestored;
        e.action = GuardEvent::Action::kRestore;
        e.time = e.rollback_to = t;
        e.time_step = h_;
        e.integrator = integrator_;
        push_event(e);
        apply(world);
      }
      if (goal == 0) return true;
      continue;
    }
    ++detections_;
    const double t_fail = world->time();
    rollback(world);
    const bool ok = reduce(*world, p, t_fail);
    apply(world);
    if (!ok) {
      failed_ = true;
      return false;
    }
  }
}

}  // namespace corde
