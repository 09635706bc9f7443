#include "corde_sim/scene/scene_runner.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>

#include "corde_sim/grasp/grasp.h"
#include "corde_sim/integrators/integrator_names.h"
#include "corde_sim/simulation/simulation.h"
#include "corde_sim/stability/explicit_step_limit.h"

namespace corde {

void write_csv_header(std::ostream& out) { out << "t,rod,segment,x0,y0,z0,x1,y1,z1,qx,qy,qz,qw\n"; }

namespace {

// RFC 4180: a field with a comma, quote or line break is quoted, its quotes doubled.
std::string csv_field(const std::string& s) {
  if (s.find_first_of(",\"\r\n") == std::string::npos) return s;
  std::string out = "\"";
  for (char c : s) out += c == '"' ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

}  // namespace

void write_csv_rows(std::ostream& out, const World& world) {
  char buf[256];  // 12 numbers of at most 16 characters and the segment index
  std::string row;
  for (const Rod& rod : world.rods()) {
    const std::string name = csv_field(rod.name());
    const auto& x = rod.positions();
    const auto& q = rod.orientations();
    for (int s = 0; s < rod.num_segments(); ++s) {
      std::snprintf(buf, sizeof buf, "%.9g,", world.time());
      row = buf;
      row += name;
      std::snprintf(buf, sizeof buf, ",%d,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g\n", s,
                    x[s].x(), x[s].y(), x[s].z(), x[s + 1].x(), x[s + 1].y(), x[s + 1].z(),
                    q[s].x(), q[s].y(), q[s].z(), q[s].w());
      row += buf;
      out << row;
    }
  }
}

void write_reaction_header(std::ostream& out) {
  out << "t,support,rod,fx,fy,fz,mx,my,mz,px,py,pz\n";
}

void write_reaction_rows(std::ostream& out, const Scene& scene) {
  char buf[320];
  for (const Support& support : scene.supports) {
    const Wrench w = support_reaction(scene.world.rod(support.rod), support);
    std::snprintf(buf, sizeof buf, "%.9g,", scene.world.time());
    std::string row = buf;
    row += csv_field(support.name) + "," + csv_field(support.rod);
    std::snprintf(buf, sizeof buf, ",%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g\n", w.force.x(),
                  w.force.y(), w.force.z(), w.moment.x(), w.moment.y(), w.moment.z(), w.point.x(),
                  w.point.y(), w.point.z());
    out << row << buf;
  }
}

void write_energy_header(std::ostream& out) {
  out << "t,rod,kinetic_translation,kinetic_rotation,stretch,bend_twist,coupling,gravity,total\n";
}

void write_energy_rows(std::ostream& out, const World& world) {
  char buf[320];
  for (const Rod& rod : world.rods()) {
    const Energies e = rod.energies(world.gravity_at(world.time()));
    std::snprintf(buf, sizeof buf, "%.9g,", world.time());
    std::string row = buf + csv_field(rod.name());
    std::snprintf(buf, sizeof buf, ",%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g\n", e.kinetic_translation,
                  e.kinetic_rotation, e.stretch, e.bend_twist, e.coupling, e.gravity,
                  e.kinetic() + e.elastic() + e.gravity);
    out << row << buf;
  }
}

std::string run_problem(const World& world, const RunOptions& options) {
  return check_state(world, options.limits).message();
}

void drive_scene(Simulation* sim, Scene* scene) {
  // Grasps hold their segments where they take hold or move them exactly along their keyframes
  // (GraspSpec::motion; the ROS node moves them through holders from its inputs instead); a
  // grasp with grasp_time or release_time takes hold and lets go in the step nearest those times.
  sim->attach(&scene->world);
  for (const GraspSpec& spec : scene->grasps) {
    if (!spec.grip.friction) {
      sim->add_script(spec, ScriptDrive::kExact);
      continue;
    }
    // A friction grasp slides through its fingers: one of the driver's grasps, its holder on the
    // keyframes (the holder limits apply).
    World& w = sim->world();
    const Rod& rod = w.rod(spec.rod);
    const std::string error =
        sim->grasps().add(w, spec, segment_pose(rod, grasp_segment(rod, spec)), nullptr, w.time());
    if (!error.empty()) throw SceneError("grasp '" + spec.name + "': " + error);
    sim->add_script(spec, ScriptDrive::kHolder);
  }
}

RunResult run_scene(Scene* scene, const RunOptions& options) {
  using Clock = std::chrono::steady_clock;
  const double h = scene->world.time_step;
  const double duration = options.duration >= 0.0 ? options.duration : scene->duration;
  // In double first: duration / h can exceed any integer (undefined behaviour when converted).
  const double n = std::ceil(duration / h - 1e-9);
  if (!(h > 0.0) || !(n <= options.max_steps)) {
    char buf[200];
    std::snprintf(buf, sizeof buf,
                  "duration %g s at time_step %g s needs %g steps, more than the limit of %g "
                  "(max_steps)",
                  duration, h, n, options.max_steps);
    throw SceneError(buf);
  }
  const long steps = std::max(0L, static_cast<long>(n));
  RunResult r;
  r.every = options.every > 0
                ? options.every
                : static_cast<int>(std::clamp(std::round(0.01 / h), 1.0, 1e9));  // fits an int
  Simulation sim(options.guard);
  drive_scene(&sim, scene);
  const World& world = sim.world();
  // Deep contacts: counted every step, reported (throttled) with the rods and obstacles named.
  double next_deep_report = -INFINITY;
  sim.set_step_observer([&](const World& w) {
    const ContactSystem* cs = w.contacts();
    if (!cs || !(cs->stats().max_ratio > w.contact.deep_penetration)) return;
    ++r.deep_contact_steps;
    const double ratio = cs->stats().max_ratio;
    const bool deepest = ratio > r.deepest_contact;
    if (!deepest && !(options.on_deep_contact && w.time() >= next_deep_report)) return;
    const std::string report = deep_contact_report(w, w.contact.deep_penetration);
    if (deepest) {
      r.deepest_contact = ratio;
      r.deepest_contact_time = w.time();
      r.deepest_contact_report = report;
    }
    if (options.on_deep_contact && w.time() >= next_deep_report) {
      next_deep_report = w.time() + options.deep_contact_interval;
      options.on_deep_contact(w.time(), report);
    }
  });
  const bool any_output = options.csv || options.reactions || options.energies;
  const Clock::time_point start = Clock::now();
  Clock::time_point last_report = start;
  auto wall = [&] { return std::chrono::duration<double>(Clock::now() - start).count(); };
  auto write = [&](bool reactions) {
    if (options.csv) write_csv_rows(*options.csv, world);
    if (options.energies) write_energy_rows(*options.energies, world);
    if (options.reactions && reactions) write_reaction_rows(*options.reactions, *scene);
    for (std::ostream* out : {options.csv, options.energies, options.reactions})
      if (out && !*out) r.write_failed = true;
  };
  r.problem = run_problem(world, options);  // the scene's own start (initial velocities...)
  if (!r.problem.empty()) {
    r.ok = false;
    r.failed_step = 0;
    r.failed_time = world.time();
  }
  if (options.csv) write_csv_header(*options.csv);
  if (options.energies) write_energy_header(*options.energies);
  if (options.reactions) write_reaction_header(*options.reactions);
  if (any_output && r.ok) write(false);
  const double t_start = world.time();
  auto take_events = [&] {
    for (const SimulationEvent& e : sim.take_events()) {
      if (e.kind != SimulationEvent::Kind::kGuard) continue;
      r.guard_events.push_back(e.guard);
      if (options.on_guard_event) options.on_guard_event(e.guard);
    }
  };
  const bool guarded = options.guard.enabled;
  r.guarded = guarded;
  // Steps in batches up to the next frame, progress report or (without the guard) runaway check.
  for (long i = 0; r.ok && i < steps && !r.write_failed;) {
    long next = std::min(steps, (i / 256 + 1) * 256);
    if (any_output) next = std::min(next, (i / r.every + 1) * r.every);
    if (!guarded) next = std::min(next, (i / 8 + 1) * 8);
    const bool frame = any_output && (next % r.every == 0 || next == steps);
    bool good = sim.advance(next - i);
    // No frame and no end state unchecked: the guard checks them now.
    if (good && guarded && (frame || next == steps)) good = sim.settle();
    take_events();
    if (!good) {
      // The world is back at its last good state, a whole number of steps from the start.
      const StepGuard& guard = sim.guard();
      r.steps = std::lround((world.time() - t_start) / h);
      r.ok = false;
      r.guard_failed = true;
      r.problem = guard.events().empty() ? "the guard gave up" : guard.events().back().message();
      r.failed_step = r.steps;
      r.failed_time = world.time();
      break;
    }
    i = next;
    r.steps = i;
    // Every 8 steps without the guard (a blow-up grows over tens of steps; checking every step
    // would cost about 10% of a small rod's step), and before every frame, so that no bad state
    // is written.
    const bool check = frame || i == steps || !guarded;
    const std::string problem = check ? run_problem(world, options) : std::string();
    if (!problem.empty()) {
      r.ok = false;
      r.problem = problem;
      r.failed_step = i;
      r.failed_time = world.time();
      break;
    }
    if (frame) write(true);
    if (options.progress && (i & 255) == 0) {
      const Clock::time_point now = Clock::now();
      if (std::chrono::duration<double>(now - last_report).count() >= options.progress_interval) {
        last_report = now;
        options.progress(static_cast<double>(i) / steps, world.time(), wall());
      }
    }
  }
  r.guard_rollbacks = sim.guard().rollbacks();
  r.guard_work = sim.guard().total_work();
  r.wall_seconds = wall();
  r.sim_time = world.time();
  r.energies = world.energies();
  return r;
}

std::string scene_header(const Scene& scene) {
  std::string rods;
  for (const Rod& rod : scene.world.rods())
    rods += (rods.empty() ? "" : ", ") + rod.name() + " (" + std::to_string(rod.num_segments()) +
            " elements)";
  return "scene      " + scene.name + " (" + scene.source + ")\nrods       " + rods + "\n";
}

std::string run_summary(const Scene& scene, const RunResult& r) {
  char buf[512];
  std::string out = scene_header(scene);
  for (const std::string& note : scene.notes) out += "chosen     " + note + "\n";
  const bool limited = has_explicit_step_limit(scene.world.integrator);
  for (const Rod& rod : scene.world.rods()) {
    const StabilityEstimate e = estimate_stability(rod);
    std::snprintf(buf, sizeof buf,
                  "stability  %s: step limit %.3g s (%s), time step %.2f of it%s\n",
                  rod.name().c_str(), e.time_step, e.limiting.c_str(),
                  scene.world.time_step / e.time_step, limited ? "" : " (explicit methods only)");
    out += buf;
  }
  std::snprintf(buf, sizeof buf, "steps      %ld of %.3g s (%s), %.6g s simulated\n", r.steps,
                scene.world.time_step, integrator_name(scene.world.integrator), r.sim_time);
  out += buf;
  const double per_step = r.steps > 0 ? r.wall_seconds / r.steps * 1e6 : 0.0;
  std::snprintf(buf, sizeof buf, "wall time  %.3f s, %.3g us/step, real-time factor %.3g\n",
                r.wall_seconds, per_step, r.wall_seconds > 0 ? r.sim_time / r.wall_seconds : 0.0);
  out += buf;
  std::snprintf(buf, sizeof buf, "energy     kinetic %.6g J, elastic %.6g J%s\n",
                r.energies.kinetic(), r.energies.elastic(), r.ok ? "" : " (at failure)");
  out += buf;
  int detected = 0, restored = 0;
  for (const GuardEvent& e : r.guard_events) {
    if (e.kind == GuardEvent::Kind::kRestored)
      ++restored;
    else if (e.kind != GuardEvent::Kind::kUnrecoverable)
      ++detected;
  }
  if (!r.guarded)
    std::snprintf(buf, sizeof buf, "guard      off\n");
  else if (r.guard_failed)
    std::snprintf(buf, sizeof buf,
                  "guard      UNRECOVERABLE after %d detection(s), %ld rollback(s)\n", detected,
                  r.guard_rollbacks);
  else if (detected > 0)
    std::snprintf(buf, sizeof buf,
                  "guard      recovered: %d detection(s), %ld rollback(s), %d return(s) to the "
                  "scene's step\n",
                  detected, r.guard_rollbacks, restored);
  else
    std::snprintf(buf, sizeof buf, "guard      no events\n");
  out += buf;
  if (r.deep_contact_steps > 0) {
    std::snprintf(buf, sizeof buf,
                  "contacts   deep in %ld step(s), deepest %.3g radii at t = %.6g s: ",
                  r.deep_contact_steps, r.deepest_contact, r.deepest_contact_time);
    out += buf + r.deepest_contact_report + "\n";
  }
  return out;
}

}  // namespace corde
