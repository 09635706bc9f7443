#include "corde_sim/scene/automatic_choices.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "corde_sim/stability/explicit_step_limit.h"

namespace corde {
namespace {

// The tightest bound so far and what set it.
struct Bound {
  double h;
  std::string why;
  void take(double value, const std::string& reason) {
    if (value > 0.0 && value < h) {
      h = value;
      why = reason;
    }
  }
};

std::string fmt(const char* f, double a, double b = 0.0) {
  char buf[200];
  std::snprintf(buf, sizeof buf, f, a, b);
  return buf;
}

// Angle of a rotation (rad).
double angle_of(const Quat& q) { return 2.0 * std::atan2(q.vec().norm(), std::abs(q.w())); }

// A keyframed motion's bounds: its mean speeds between keyframes (the smooth profiles peak at
// 1.5 of them) against the element length, its turning per step, and its intervals.
void motion_bounds(const Motion& m, double element, const std::string& who, Bound* b) {
  const auto& k = m.keyframes();
  for (size_t i = 1; i < k.size(); ++i) {
    const double dt = k[i].time - k[i - 1].time;
    if (!(dt > 0.0)) continue;
    b->take(dt / 10.0, who + ": a keyframe interval of " + fmt("%.3g s takes 10 steps", dt));
    const double v = 1.5 * (k[i].displacement - k[i - 1].displacement).norm() / dt;
    if (v > 0.0)
      b->take(0.5 * element / v,
              who + fmt(": moving at up to %.3g m/s, half an element (%.3g m) per step", v,
                        0.5 * element));
    const double w = 1.5 *
                     (angle_of(k[i - 1].rotation.conjugate() * k[i].rotation) +
                      std::abs(k[i].angle - k[i - 1].angle)) /
                     dt;
    if (w > 0.0) b->take(0.1 / w, who + fmt(": turning at up to %.3g rad/s, 0.1 rad per step", w));
  }
}

}  // namespace

ImplicitStepChoice implicit_time_step(const Scene& scene) {
  const World& world = scene.world;
  Bound b{kFrameStep, "the 2 ms frame"};
  b.take(scene.duration / 50.0, fmt("duration / 50 (%.3g s)", scene.duration));
  const double g = world.gravity.norm();
  for (const Rod& rod : world.rods()) {
    const Section& s = rod.section();
    double length = 0.0, element = INFINITY;
    for (double l : rod.rest_lengths()) {
      length += l;
      element = std::min(element, l);
    }
    bool clamped = rod.ghost_start().active || rod.ghost_end().active ||
                   !rod.segment_drives().empty() || !rod.segment_constraints().empty();
    bool held = clamped || !rod.node_drives().empty() || !rod.node_constraints().empty();
    // Only a grasp that holds for the whole run: a late or released one leaves the rod free for
    // a while, and a free rod's lowest mode is the higher one (the smaller step).
    for (const GraspSpec& spec : scene.grasps)
      if (spec.rod == rod.name() && spec.grasp_time <= 0.0 && std::isinf(spec.release_time)) {
        held = true;
        clamped = clamped || spec.hold_orientation;
      }
    const double beta = (clamped ? 1.875 : held ? 3.927 : 4.730) / length;
    const double bending = beta * beta * std::sqrt(s.bend / s.mass_per_length);
    const double pendulum = held ? std::sqrt(g / length) : 0.0;
    const double omega = std::max(bending, pendulum);
    const std::string who = "rod '" + rod.name() + "'";
    const bool bdf2 = world.integrator == Integrator::kBdf2;
    if (omega > 0.0)
      b.take((bdf2 ? 0.2 : 0.0335) / omega,
             who + fmt(": its lowest mode (%.3g rad/s", omega) +
                 (bending >= pendulum ? ", bending" : ", pendulum") +
                 (bdf2 ? ") keeps its period to 1.3% and loses 1.1% of its amplitude per period"
                       : ") loses at most 10% of its amplitude per period"));
    for (const NodeDrive& d : rod.node_drives()) {
      const std::string node = who + " node " + std::to_string(d.node);
      if (d.kind == NodeDrive::Kind::kVelocity && d.velocity.norm() > 0.0)
        b.take(0.5 * element / d.velocity.norm(),
               node + fmt(": moving at %.3g m/s, half an element (%.3g m) per step",
                          d.velocity.norm(), 0.5 * element));
      if (d.kind == NodeDrive::Kind::kMotion && d.motion)
        motion_bounds(*d.motion, element, node, &b);
    }
    for (const SegmentDrive& d : rod.segment_drives()) {
      const std::string seg = who + " segment " + std::to_string(d.segment);
      if (d.kind == SegmentDrive::Kind::kSpin && d.rate != 0.0)
        b.take(0.1 / std::abs(d.rate),
               seg + fmt(": spinning at %.3g rad/s, 0.1 rad per step", std::abs(d.rate)));
      if (d.kind == SegmentDrive::Kind::kMotion && d.motion)
        motion_bounds(*d.motion, element, seg, &b);
    }
    for (const GhostFrame* gf : {&rod.ghost_start(), &rod.ghost_end()})
      if (gf->active && gf->motion) motion_bounds(*gf->motion, element, who + " clamp", &b);
    for (const Load& l : rod.loads())
      if (l.ramp_time > 0.0)
        b.take(l.ramp_time / 10.0,
               who + fmt(": a load ramped over %.3g s takes 10 steps", l.ramp_time));
    for (const GraspSpec& spec : scene.grasps)
      if (spec.rod == rod.name() && spec.motion)
        motion_bounds(*spec.motion, element, "grasp '" + spec.name + "'", &b);
  }
  return {b.h, b.why};
}

double explicit_time_step(const World& world, std::string* why) {
  // The start shape's own limit where it is lower (a rod built bent, stretched or compressed).
  const WorldStepLimit l = explicit_step_limit(world, true);
  if (l.rod >= 0)
    *why = "the stability limit of rod '" + world.rods()[l.rod].name() + "' (" +
           (l.limiting == "start shape" ? std::string("modes of its start shape")
                                        : l.limiting + " modes") +
           ")";
  const double limit = l.time_step;
  return limit > 0.0 && std::isfinite(limit) ? 0.8 * limit : 0.0;
}

namespace {

// The work of a step counted in element evaluations (one element's forces and torques: what an
// explicit step does per element). The implicit step costs, per element, a fixed part (the
// residual, drives, the line search's energies), a part per Newton iteration (gradient and
// Hessian blocks) and a part per factorisation (the block Cholesky; a factor is reused while the
// rods barely move); a contact stage costs its detection per element, every step. The weights
// are fixed ratios, fitted once to the thread CPU times of 13 shipped scenes under both methods
// (docs/benchmark.md): the choice depends on the scene, never on the machine it runs on.
constexpr double kImplicitStepWork = 8.0;      // per element and implicit step
constexpr double kNewtonIterationWork = 4.0;   // per element and Newton iteration
constexpr double kFactorisationWork = 7.0;     // per element and factorisation
constexpr double kContactDetectionWork = 1.2;  // per element and step with a contact stage

struct TrialWork {
  double per_step = 0.0;        // element evaluations per step, averaged over the trial
  double iterations = 0.0;      // Newton iterations per step (implicit, the most any rod took)
  double factorisations = 0.0;  // factorisations per step and rod (implicit)
  bool detection = false;       // the world has a contact stage
};

// `steps` steps of `integrator` at step h on a copy of the world, their work counted. The same
// scene gives the same count on any machine. Throws what the step throws; per_step NaN if the
// copy's state turned non-finite.
TrialWork trial_work(const World& world, Integrator integrator, double h, int steps) {
  World w = world;
  w.integrator = integrator;
  w.time_step = h;
  const bool implicit = is_implicit(integrator);
  double elements = 0.0;
  for (const Rod& rod : world.rods()) elements += rod.num_segments();
  const double rods = static_cast<double>(std::max<size_t>(1, world.rods().size()));
  TrialWork t;
  double work = 0.0;
  for (int i = 0; i < steps; ++i) {
    const long factorised = w.implicit_factorisations();
    w.step();
    const double iterations = implicit ? w.implicit_stats().iterations : 0.0;
    const double factorisations =
        implicit ? static_cast<double>(w.implicit_factorisations() - factorised) / rods : 0.0;
    double per_element = implicit ? kImplicitStepWork + kNewtonIterationWork * iterations +
                                        kFactorisationWork * factorisations
                                  : 1.0;
    if (w.contacts()) per_element += kContactDetectionWork;
    work += elements * per_element;
    t.iterations += iterations / steps;
    t.factorisations += factorisations / steps;
    t.detection = t.detection || w.contacts();
  }
  t.per_step = w.finite() ? work / steps : NAN;
  return t;
}

constexpr int kExplicitTrialSteps = 32;
constexpr int kImplicitTrialSteps = 8;

}  // namespace

IntegratorChoice choose_integrator(const Scene& scene, double given_step) {
  const World& world = scene.world;
  IntegratorChoice c;
  std::string limit_why;
  const double explicit_h = explicit_time_step(world, &limit_why);
  const char* explicit_name = integrator_name(kDefaultIntegrator);
  if (given_step > 0.0) {
    c.time_step = given_step;
    if (explicit_h > 0.0 && given_step <= explicit_h / 0.8) {
      c.integrator = kDefaultIntegrator;
      c.reason = std::string("integrator: auto chose ") + explicit_name + ": the time_step " +
                 fmt("%.3g s is within %.3g s, ", given_step, explicit_h / 0.8) + limit_why +
                 ", and an explicit step costs less than an implicit one at the same step";
    } else {
      c.integrator = Integrator::kImplicitEuler;
      c.reason = std::string("integrator: auto chose implicit_euler: the time_step ") +
                 fmt("%.3g s exceeds %.3g s, ", given_step, explicit_h / 0.8) + limit_why +
                 ", beyond which " + explicit_name + " is unstable";
    }
    return c;
  }
  const ImplicitStepChoice implicit = implicit_time_step(scene);
  c.explicit_step = explicit_h;
  c.implicit_step = implicit.time_step;
  std::string implicit_problem;
  TrialWork im_work, ex_work;
  try {
    im_work =
        trial_work(world, Integrator::kImplicitEuler, implicit.time_step, kImplicitTrialSteps);
    c.implicit_cost = im_work.per_step;
    if (std::isnan(c.implicit_cost)) implicit_problem = "its trial steps turned non-finite";
  } catch (const std::exception& e) {
    implicit_problem = e.what();
  }
  if (explicit_h > 0.0) {
    ex_work = trial_work(world, kDefaultIntegrator, explicit_h, kExplicitTrialSteps);
    c.explicit_cost = ex_work.per_step;
  }
  const double explicit_rate = explicit_h > 0.0 ? c.explicit_cost / explicit_h : INFINITY;
  const double implicit_rate =
      implicit_problem.empty() ? c.implicit_cost / implicit.time_step : INFINITY;
  const std::string ex = std::string(explicit_name) + fmt(" at %.3g s steps (0.8 x ", explicit_h) +
                         limit_why + ") costs " +
                         fmt("%.3g element evaluations per step", c.explicit_cost) +
                         (ex_work.detection ? " (with contact detection)" : "") +
                         fmt(", %.3g per simulated s", explicit_rate);
  const std::string im =
      implicit_problem.empty()
          ? fmt("implicit_euler at %.3g s steps (", implicit.time_step) + implicit.why +
                fmt(") costs %.3g element evaluations per step (%.3g Newton iterations",
                    c.implicit_cost, im_work.iterations) +
                fmt(", %.3g factorisations", im_work.factorisations) +
                (im_work.detection ? ", contact detection" : "") +
                fmt("), %.3g per simulated s", implicit_rate)
          : "implicit_euler failed its trial (" + implicit_problem + ")";
  if (!(explicit_rate <= implicit_rate) && implicit_problem.empty()) {
    c.integrator = Integrator::kImplicitEuler;
    c.time_step = implicit.time_step;
    c.reason = "integrator: auto chose implicit_euler, " +
               fmt("%.3g", explicit_rate / implicit_rate) + "x cheaper: " + im + "; " + ex;
  } else {
    c.integrator = kDefaultIntegrator;
    c.time_step = explicit_h;
    c.reason =
        std::string("integrator: auto chose ") + explicit_name +
        (implicit_problem.empty() ? fmt(", %.3g", implicit_rate / explicit_rate) + "x cheaper"
                                  : std::string()) +
        ": " + ex + "; " + im;
  }
  return c;
}

}  // namespace corde
