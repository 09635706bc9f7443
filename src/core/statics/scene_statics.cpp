#include "corde_sim/statics/scene_statics.h"

#include <Eigen/SparseCholesky>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "corde_sim/grasp/grasp.h"
#include "corde_sim/grasp/reactions.h"
#include "corde_sim/model/loads.h"
#include "corde_sim/scene/scene_runner.h"
#include "corde_sim/statics/static_hessian.h"

namespace corde {
namespace {

constexpr int kAttempts = 4;  // load steps m, 4m, 16m, 64m
constexpr int kMaxMotionSteps = 256;
// Continuation steps along a drive's path: at most this much of the rod's length, or of a turn
// (rad), per load step, so that a twisted or swung end is followed rather than jumped.
constexpr double kStepMove = 0.05, kStepTurn = 0.25;

std::string g_fmt(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.4g", v);
  return buf;
}

double angle_between(const Quat& a, const Quat& b) {
  return 2.0 * std::acos(std::min(1.0, std::abs(a.coeffs().dot(b.coeffs()))));
}

// Holds the rod's grasps that hold at t as run_scene does: where they take hold, or where their
// keyframes have moved the holder by t. Statics does not follow the rod's motion before a late
// grasp takes hold: its holder starts at the segment's pose in the scene as given.
void hold_grasps(const Scene& scene, Rod* rod, double t) {
  for (const GraspSpec& spec : scene.grasps) {
    if (spec.rod != rod->name() || !grasp_holds(spec, t, 0.0)) continue;
    const Eigen::Isometry3d start = segment_pose(*rod, grasp_segment(*rod, spec));
    const Grasp g = make_grasp(*rod, spec, start);
    const std::shared_ptr<const Motion> motion = holder_motion(spec, start);
    hold(*rod, g, motion ? motion->pose_at(t - spec.grasp_time, start) : start);
  }
}

// The load steps that follow the drives from where the rod is to their state at t in moves of at
// most kStepMove of the rod's length and kStepTurn rad (paths sampled at 64 points; grasp targets
// are reached along the straight line and the shortest turn, as statics.h interpolates them).
int motion_steps(const Rod& rod, double t) {
  double length = 0.0, move = 0.0, turn = 0.0;
  for (double l : rod.rest_lengths()) length += l;
  constexpr int kSamples = 64;
  for (const NodeDrive& d : rod.node_drives()) {
    if (d.kind == NodeDrive::Kind::kTarget) {
      move = std::max(move, (d.target - rod.positions()[d.node]).norm());
      continue;
    }
    double path = 0.0;
    Vec3 last = rod.positions()[d.node];
    for (int k = 1; k <= kSamples && t > 0.0; ++k) {
      const Vec3 x = drive_position(d, t * k / kSamples);
      path += (x - last).norm();
      last = x;
    }
    move = std::max(move, path);
  }
  auto turned = [&](auto at, const Quat& from) {
    double path = 0.0;
    Quat last = from;
    for (int k = 1; k <= kSamples && t > 0.0; ++k) {
      const Quat q = at(t * k / kSamples);
      path += angle_between(q, last);
      last = q;
    }
    return path;
  };
  for (const SegmentDrive& d : rod.segment_drives()) {
    const Quat& q0 = rod.orientations()[d.segment];
    turn = std::max(turn, d.kind == SegmentDrive::Kind::kTarget
                              ? angle_between(d.target, q0)
                              : turned([&](double s) { return drive_orientation(d, s); }, q0));
  }
  for (const GhostFrame* g : {&rod.ghost_start(), &rod.ghost_end()})
    if (g->active)
      turn = std::max(turn, turned([&](double s) { return ghost_frame_at(*g, s); }, g->frame));
  const double steps = std::max(move / (kStepMove * length), turn / kStepTurn);
  return static_cast<int>(std::clamp(std::ceil(steps), 1.0, double(kMaxMotionSteps)));
}

// Inertia of the Hessian at the solution: its LDL^T's pivots have the signs of its eigenvalues.
void classify(Rod* rod, const Vec3& gravity, double t, RodEquilibrium* e) {
  const Eigen::SparseMatrix<double> h = static_hessian(*rod, gravity, t);
  e->negative_modes = e->zero_modes = 0;
  e->potential = true;
  for (const Load& l : rod->loads())
    if (!load_has_potential(l) && l.scale(t) != 0.0) e->potential = false;
  if (h.rows() == 0) return;
  const Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(h);
  const Eigen::VectorXd d = ldlt.vectorD();
  if (ldlt.info() != Eigen::Success || !d.allFinite()) {
    e->negative_modes = e->zero_modes = -1;
    return;
  }
  // Round-off of the pivots is ~eps times the stiffest entry; soft physical modes (a hanging
  // cable's swing against its stretch) sit at ~1e-6 of it.
  const double zero = 1e-11 * d.cwiseAbs().maxCoeff();
  for (int i = 0; i < d.size(); ++i) {
    if (std::abs(d(i)) <= zero)
      ++e->zero_modes;
    else if (d(i) < 0.0)
      ++e->negative_modes;
  }
}

void measure_sag(const Rod& rod, RodEquilibrium* e) {
  const auto& x = rod.positions();
  e->lowest_node = 0;
  for (int i = 1; i < rod.num_nodes(); ++i)
    if (x[i].z() < x[e->lowest_node].z()) e->lowest_node = i;
  e->lowest_z = x[e->lowest_node].z();
  e->support_z = NAN;
  for (const NodeDrive& d : rod.node_drives())
    if (!(x[d.node].z() >= e->support_z)) e->support_z = x[d.node].z();
  e->sag = e->support_z - e->lowest_z;
}

// One rod at time t, grasps already held: continuation retries from the same start. With
// `complete_ramps`, loads that have started by t act at their full value: a ramp only keeps a
// dynamic run from ringing, and the solve's own continuation takes its place.
RodEquilibrium solve_rod(Rod* rod, const Vec3& gravity, double t, StaticOptions options,
                         bool complete_ramps) {
  RodEquilibrium e;
  e.rod = rod->name();
  const std::vector<Load> loads = rod->loads();
  if (complete_ramps)
    for (Load& l : rod->loads())
      if (l.t_start <= t) l.ramp_time = 0.0;
  const Rod start = *rod;
  int steps = std::max({1, options.load_steps, motion_steps(*rod, t)});
  for (int a = 0; a < kAttempts; ++a, steps *= 4) {
    if (a > 0) *rod = start;
    options.load_steps = steps;
    try {
      e.result = solve_statics(*rod, gravity, t, options);
    } catch (const std::invalid_argument& ex) {  // statics_unsupported() should have caught it
      throw SceneError(ex.what());
    }
    e.attempts = a + 1;
    e.result.converged = e.result.converged && rod->finite();
    if (e.result.converged) break;
  }
  if (e.result.converged) classify(rod, gravity, t, &e);
  rod->set_static_reactions(t, gravity);
  rod->loads() = loads;
  measure_sag(*rod, &e);
  return e;
}

std::string not_converged(const RodEquilibrium& e, double t) {
  const StaticResult& r = e.result;
  return "rod '" + e.rod + "': no static equilibrium found at t = " + g_fmt(t) +
         " s: the residual stayed at " + g_fmt(r.residual) + " N (" + g_fmt(r.relative_residual) +
         " of the loads, tolerance " + g_fmt(StaticOptions().tolerance) + ") after " +
         std::to_string(e.attempts) + " attempts, the last with " + std::to_string(r.load_steps) +
         " load steps and " + std::to_string(r.iterations) +
         " Newton iterations; the rod may have no equilibrium near this path (e.g. loaded far "
         "beyond buckling, or held too loosely), try a dynamic run";
}

bool held(const Scene& scene, const Rod& rod, double t) {
  if (!rod.node_drives().empty() || !rod.node_constraints().empty()) return true;
  for (const GraspSpec& g : scene.grasps)
    if (g.rod == rod.name() && grasp_holds(g, t, 0.0)) return true;
  return false;
}

std::string rod_unsupported(const Scene& scene, const Rod& rod, double t) {
  const std::string who = "rod '" + rod.name() + "'";
  const std::string no_contacts =
      "; statics solves no contacts (its equilibrium would pass through them): ";
  for (const Load& l : rod.loads())
    if (l.follower)
      return who + ": the " +
             (l.kind == Load::Kind::kForce ? "force on node " : "torque on segment ") +
             std::to_string(l.index) +
             " is a follower load (kind: follower), which turns with the rod and has no potential "
             "energy, so statics cannot solve for it; use a dead load or a dynamic run";
  if (!rod.segment_constraints().empty())
    return who + ": segment " + std::to_string(rod.segment_constraints().front().segment) +
           " turns about an axis (free_axis:, or a clamp with twist: free), which statics does "
           "not handle; hold the segment or use a dynamic run";
  const ContactOptions& o = rod.contact_options();
  if (o.obstacles && scene.world.obstacles && scene.world.obstacles->size() > 0)
    return who + " touches the scene's obstacles (contact.obstacles)" + no_contacts +
           "set contact: {obstacles: false} on the rod if it cannot reach them, or use a dynamic "
           "run";
  if (o.self)
    return who + " has self contact (contact.self)" + no_contacts +
           "set contact: {self: false} or use a dynamic run";
  if (o.rods) {
    int others = 0;
    for (const Rod& r : scene.world.rods()) others += &r != &rod && r.contact_options().rods;
    if (others > 0)
      return who + " takes part in rod-rod contact (contact.rods)" + no_contacts +
             "set contact: {rods: false} or use a dynamic run";
  }
  bool loaded = scene.world.gravity.norm() > 0.0;
  for (const Load& l : rod.loads()) loaded = loaded || l.value.norm() > 0.0;
  if (loaded && !held(scene, rod, t))
    return who + " is held nowhere at t = " + g_fmt(t) +
           " s (no clamp, fixed or driven node, or grasp holding then): under gravity and its "
           "loads it has no equilibrium, it falls";
  return "";
}

}  // namespace

std::string statics_unsupported(const Scene& scene, const std::string& rod, double t) {
  for (const Rod& r : scene.world.rods()) {
    if (!rod.empty() && r.name() != rod) continue;
    const std::string why = rod_unsupported(scene, r, t);
    if (!why.empty()) return why;
  }
  return "";
}

SceneEquilibrium solve_scene_statics(Scene* scene, double t, const StaticOptions& options) {
  if (!(t >= 0.0) || !std::isfinite(t))
    throw SceneError("statics: the time must be finite and >= 0, got " + g_fmt(t));
  const std::string why = statics_unsupported(*scene, "", t);
  if (!why.empty()) throw SceneError("statics: " + why);
  const auto start = std::chrono::steady_clock::now();
  SceneEquilibrium eq;
  eq.time = t;
  World& world = scene->world;
  for (Rod& rod : world.rods()) {
    hold_grasps(*scene, &rod, t);
    // Like the loads that have started, gravity acts whole (its ramp only keeps a run calm).
    eq.rods.push_back(solve_rod(&rod, world.gravity, t, options, true));
    if (!eq.rods.back().result.converged && eq.ok) {
      eq.ok = false;
      eq.problem = not_converged(eq.rods.back(), t);
    }
  }
  world.set_time(t);
  eq.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return eq;
}

RodEquilibrium settle_rod(Scene* scene, Rod* rod) {
  const std::string why = rod_unsupported(*scene, *rod, 0.0);
  if (!why.empty()) throw SceneError(why);
  const Rod given = *rod;
  hold_grasps(*scene, rod, 0.0);
  // The loads and gravity as the run starts with them (a ramp from zero: none), so that it starts
  // at rest.
  RodEquilibrium e = solve_rod(rod, scene->world.gravity_at(0.0), 0.0, StaticOptions(), false);
  if (!e.result.converged) throw SceneError(not_converged(e, 0.0));
  // Keep the shape; the grasps' drives are the run's to add (as before), the rest as given.
  const std::vector<Vec3> x = rod->positions();
  const std::vector<Quat> q = rod->orientations();
  *rod = given;
  rod->positions() = x;
  rod->orientations() = q;
  for (Vec3& v : rod->velocities()) v.setZero();
  for (Vec3& w : rod->angular_velocities()) w.setZero();
  return e;
}

const std::vector<std::string>& sensitivity_parameters() {
  static const std::vector<std::string> names{"E", "G", "E_s", "B", "C", "K_s", "kappa", "rho"};
  return names;
}

std::vector<StaticSensitivity> scene_statics_sensitivity(
    Scene* scene, const std::string& rod, double t, const std::vector<std::string>& parameters) {
  World& world = scene->world;
  int index = -1;
  std::string names;
  for (size_t i = 0; i < world.rods().size(); ++i) {
    if (world.rods()[i].name() == rod) index = static_cast<int>(i);
    names += (i ? ", " : "") + world.rods()[i].name();
  }
  if (index < 0)
    throw SceneError("statics sensitivity: no rod named '" + rod + "' (rods: " + names + ")");
  if (index >= static_cast<int>(scene->materials.size()))
    throw SceneError("statics sensitivity: rod '" + rod +
                     "' was not built from a scene's material map: which keys its section "
                     "follows is not known");
  Rod& r = world.rods()[index];
  const MaterialOrigin& o = scene->materials[index];
  const Section& sec = r.section();
  std::vector<SectionRate> rates;
  for (const std::string& given : parameters) {
    const std::string p = given == "density" ? "rho" : given;
    const std::vector<std::string>& known = sensitivity_parameters();
    if (std::find(known.begin(), known.end(), p) == known.end()) {
      std::string list;
      for (const std::string& k : known) list += (list.empty() ? "" : ", ") + k;
      throw SceneError("statics sensitivity: unknown parameter '" + given + "' (known: " + list +
                       ", density)");
    }
    double value = 0.0;
    for (const auto& [key, v] : o.values)
      if (key == p) value = v;
    SectionRate rate;
    if (value > 0.0) {
      if (o.bend == p) rate.bend = sec.bend / value;
      if (o.twist == p) rate.twist = sec.twist / value;
      if (o.stretch == p) rate.stretch = sec.stretch / value;
      if (o.kappa == p) rate.kappa = sec.kappa / value;
      if (o.mass == p) rate.mass_per_length = sec.mass_per_length / value;
    }
    if (rate.bend == 0.0 && rate.twist == 0.0 && rate.stretch == 0.0 && rate.kappa == 0.0 &&
        rate.mass_per_length == 0.0) {
      const std::string why =
          p == "rho" && value > 0.0
              ? "its density ranges give parts of it their own density, so its mass is not "
                "proportional to rho"
              : "its material derives nothing from " + p + " (bending from " + o.bend +
                    ", twist from " + o.twist + ", stretch from " + o.stretch + ", kappa from " +
                    o.kappa + ")";
      throw SceneError("statics sensitivity: rod '" + rod + "': parameter '" + given + "': " + why);
    }
    rates.push_back(rate);
  }
  // The loads as the solve had them: those that have started act whole.
  const std::vector<Load> loads = r.loads();
  for (Load& l : r.loads())
    if (l.t_start <= t) l.ramp_time = 0.0;
  try {
    std::vector<StaticSensitivity> out = static_sensitivity(r, world.gravity, t, rates);
    r.loads() = loads;
    return out;
  } catch (const std::exception& e) {
    r.loads() = loads;
    throw SceneError(e.what());
  }
}

std::string statics_summary(const Scene& scene, const SceneEquilibrium& eq) {
  char buf[512];
  std::string out = scene_header(scene);
  std::snprintf(buf, sizeof buf, "statics    equilibrium at t = %.6g s, wall time %.3g s\n",
                eq.time, eq.wall_seconds);
  out += buf;
  for (const RodEquilibrium& e : eq.rods) {
    const StaticResult& r = e.result;
    std::snprintf(buf, sizeof buf,
                  "rod        %s: %s, residual %.3g N (%.3g of the loads), %d Newton iterations, "
                  "%d load step%s, %d attempt%s\n",
                  e.rod.c_str(), r.converged ? "converged" : "NOT CONVERGED", r.residual,
                  r.relative_residual, r.iterations, r.load_steps, r.load_steps == 1 ? "" : "s",
                  e.attempts, e.attempts == 1 ? "" : "s");
    out += buf;
    if (r.converged) {
      if (!e.potential)
        out +=
            "           stability not judged: dead torques act, which have no potential "
            "energy, so the Hessian's signs do not tell\n";
      else if (e.negative_modes < 0)
        out += "           stability unknown (the Hessian's factorisation failed)\n";
      else if (e.negative_modes > 0)
        out += "           UNSTABLE: the Hessian has " + std::to_string(e.negative_modes) +
               " negative eigenvalue(s) (e.g. beyond buckling); a dynamic run leaves this "
               "state\n";
      else if (e.zero_modes > 0)
        out += "           neutral: stable but for " + std::to_string(e.zero_modes) +
               " zero-stiffness direction(s) (e.g. free to turn about a pin)\n";
      else
        out += "           stable (the Hessian is positive definite)\n";
    }
    if (std::isnan(e.support_z))
      std::snprintf(buf, sizeof buf, "           lowest node %d at z = %.6g m (no held node)\n",
                    e.lowest_node, e.lowest_z);
    else
      std::snprintf(buf, sizeof buf,
                    "           lowest node %d at z = %.6g m, sag %.6g m below the lowest held "
                    "node (z = %.6g m)\n",
                    e.lowest_node, e.lowest_z, e.sag, e.support_z);
    out += buf;
  }
  for (const Support& s : scene.supports) {
    const Wrench w = support_reaction(scene.world.rod(s.rod), s);
    std::snprintf(buf, sizeof buf,
                  "support    %s: force (%.6g, %.6g, %.6g) N, moment (%.6g, %.6g, %.6g) N m "
                  "about (%.6g, %.6g, %.6g) m\n",
                  s.name.c_str(), w.force.x(), w.force.y(), w.force.z(), w.moment.x(), w.moment.y(),
                  w.moment.z(), w.point.x(), w.point.y(), w.point.z());
    out += buf;
  }
  const WorldEnergies en = scene.world.energies();
  std::snprintf(buf, sizeof buf, "energy     elastic %.6g J, gravity %.6g J\n", en.elastic(),
                en.total.gravity);
  out += buf;
  return out;
}

}  // namespace corde
