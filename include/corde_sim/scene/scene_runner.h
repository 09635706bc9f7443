// Running a scene without ROS: the loop behind the corde_run tool.
#pragma once

#include <functional>
#include <ostream>
#include <string>
#include <vector>

#include "corde_sim/scene/scene.h"
#include "corde_sim/stability/state_checks.h"
#include "corde_sim/stability/step_guard.h"

namespace corde {

class Simulation;

struct RunOptions {
  double duration = -1.0;       // s; < 0: the scene's duration
  int every = 0;                // CSV rows every K steps (and at the start and end); 0: auto
  std::ostream* csv = nullptr;  // where to write the trajectory, or none
  // Where to write the supports' reactions and the rods' energies at the same frames (or none).
  std::ostream* reactions = nullptr;
  std::ostream* energies = nullptr;
  // Called about every `progress_interval` seconds of wall time with the fraction done.
  std::function<void(double fraction, double sim_time, double wall_seconds)> progress;
  double progress_interval = 0.25;
  // Runaway detection. An explicit step that loses stability does not always reach NaN: it can
  // run on with finite garbage (a 1 m pendulum 6 m from its pin, 1e10 J). The run stops at the
  // first state that fails these checks (stability/state_checks.h: finite, unit quaternions,
  // speeds, |axial strain| 10, specific energy 1e5 J/kg), and the CSV ends with the last frame
  // that passed them.
  StateLimits limits = runaway_state_limits();
  // Refuse runs of more steps (duration / time_step) than this: 1e15 s at 1e-300 s would
  // overflow the step counter, and 1e9 steps already take about 20 minutes for a small rod.
  double max_steps = 1e9;
  // The stability guard (stability/step_guard.h): checks every guard.check_every substeps, rolls
  // back and retries with a smaller step or the implicit method. guard.enabled = false (corde_run
  // --no-guard) runs the bare steps, with only the runaway checks above.
  GuardSettings guard;
  // Called with each guard event as it happens (corde_run prints them on stderr).
  std::function<void(const GuardEvent&)> on_guard_event;
  // Deep contacts (deeper than ContactSettings::deep_penetration times the radius: imposed by a
  // moving obstacle, a pinch, or gone through a surface): called with the world's time and
  // deep_contact_report's text at most once per deep_contact_interval of simulated time
  // (corde_run prints it on stderr).
  std::function<void(double time, const std::string& report)> on_deep_contact;
  double deep_contact_interval = 0.1;  // s
};

struct RunResult {
  long steps = 0;             // steps taken
  double sim_time = 0.0;      // s, the world's clock at the end
  double wall_seconds = 0.0;  // time spent stepping (and writing CSV)
  bool ok = true;             // false: the state failed the checks at failed_step
  std::string problem;        // why, naming the rod and item ("" when ok)
  long failed_step = -1;      // the step at which the checks failed (the guard: its last good one)
  double failed_time = 0.0;   // the world's time after that step
  WorldEnergies energies;     // at the end (or at failure)
  int every = 0;              // the CSV interval used
  bool write_failed = false;  // the CSV stream failed (disk full...): the run stopped there
  // The guard's events (detections with their actions, returns to the user's step), and whether
  // it gave up: then ok is false, problem says why, and the world is at its last good state.
  std::vector<GuardEvent> guard_events;
  bool guarded = true;  // the guard ran
  bool guard_failed = false;
  long guard_rollbacks = 0;
  double guard_work = 0.0;  // J, the guard's bound on the work done on the rods over the run
  // Deep contacts: steps whose contact stage found one, the deepest (in radii) and its report.
  long deep_contact_steps = 0;
  double deepest_contact = 0.0;
  double deepest_contact_time = 0.0;
  std::string deepest_contact_report;
};

// The CSV header: t,rod,segment,x0,y0,z0,x1,y1,z1,qx,qy,qz,qw
void write_csv_header(std::ostream& out);
// One row per segment of every rod: time, rod name, segment, its two nodes, its orientation. A
// name with a comma, quote or line break is quoted as in RFC 4180.
void write_csv_rows(std::ostream& out, const World& world);

// Reactions CSV: t,support,rod,fx,fy,fz,mx,my,mz,px,py,pz: per support (Scene::supports), the
// force and moment it exerts on the rod over the last step (world frame, N and N m, the moment
// about p), reactions.h.
void write_reaction_header(std::ostream& out);
void write_reaction_rows(std::ostream& out, const Scene& scene);
// Energies CSV: t,rod,kinetic_translation,kinetic_rotation,stretch,bend_twist,coupling,gravity,
// total (J; gravity's potential is zero at the world origin; total is their sum).
void write_energy_header(std::ostream& out);
void write_energy_rows(std::ostream& out, const World& world);

// "" if the world passes the runaway checks of `options` (check_state with options.limits), else
// the first problem found (StateProblem::message()).
std::string run_problem(const World& world, const RunOptions& options);

// Has `sim` step the scene's own world (Simulation::attach; the scene must outlive that use) as
// run_scene does, so that any caller stepping `sim` reproduces corde_run: each grasp held where it
// takes hold or moved exactly along its keyframes (ScriptDrive::kExact), a friction grasp through
// one of sim's grasps on them (ScriptDrive::kHolder). Throws SceneError for a grasp that cannot
// be made.
void drive_scene(Simulation* sim, Scene* scene);

// Steps the scene's world for the duration through the simulation driver (simulation.h),
// holding each grasp where it is at the start or moving it exactly along its keyframes
// (GraspSpec::motion, ScriptDrive::kExact), through the stability guard (options.guard).
// Reactions are written from the first step on. Stops when the guard gives up (the world at its
// last good state), at the first state that fails run_problem() (checked before every CSV frame,
// and every 8 steps without the guard, so the CSV ends with the last frame that passed) or when
// the CSV cannot be written. Throws
// SceneError if the duration needs more than options.max_steps steps (or the step is not > 0).
RunResult run_scene(Scene* scene, const RunOptions& options = {});

// The summaries' first lines: the scene (name and file) and its rods with their elements.
std::string scene_header(const Scene& scene);

// Multiline summary: scene, rods and elements, steps, simulated and wall time, time per step,
// final kinetic and elastic energy, the guard's events.
std::string run_summary(const Scene& scene, const RunResult& result);

}  // namespace corde
