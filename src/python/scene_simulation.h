// A scene and the simulation driver that steps it, as the Python module (corde_sim._core) holds
// them: stepped exactly as corde_run steps a scene (drive_scene, the stability guard, settle and
// the runaway checks before a state is shown), so that a Python run gives corde_run's numbers.
// Failures are exceptions carrying the library's messages; the world keeps its last good state.
#pragma once

#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "corde_sim/scene/scene.h"
#include "corde_sim/scene/scene_runner.h"
#include "corde_sim/simulation/simulation.h"
#include "corde_sim/statics/scene_statics.h"

namespace corde::python {

// The guard could not recover: the world is at its last good state.
struct GuardFailure : std::runtime_error {
  using std::runtime_error::runtime_error;
};
// A state failed the runaway checks (run_problem), as when corde_run exits with status 3.
struct RunawayFailure : std::runtime_error {
  using std::runtime_error::runtime_error;
};
// Statics found no equilibrium (corde_run --statics, status 4); the rods are at the last iterate.
struct StaticsFailure : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// corde_run's report of a scene error: the message, prefixed with the source unless it names it.
std::string scene_error_message(const std::string& source, const std::string& what);

class SceneSimulation {
 public:
  // Reads the scene file (or YAML text, named `source` in messages) with corde_run's --set
  // overrides. Throws SceneError with scene_error_message()'s text.
  static std::unique_ptr<SceneSimulation> load(const std::string& path,
                                               const std::vector<std::string>& overrides,
                                               const RunOptions& options);
  static std::unique_ptr<SceneSimulation> parse(const std::string& yaml,
                                                const std::vector<std::string>& overrides,
                                                const std::string& source,
                                                const RunOptions& options);

  // n steps of the scene's time step, then the guard's check of the state and the runaway
  // checks (as corde_run before each frame). Throws GuardFailure or RunawayFailure.
  void step(long n);
  // ceil(duration / time_step) steps as one batch (corde_run without output files); a negative
  // duration runs the scene's. Throws SceneError beyond options.max_steps.
  void run(double duration);
  // "" when the state passes the runaway checks, else the problem (corde_run checks the start).
  std::string problem() const { return run_problem(scene_->world, options_); }

  // The static equilibrium at time t (solve_scene_statics); the guard restarts from it. Throws
  // SceneError when statics cannot handle the scene; one that did not converge (eq.ok false)
  // leaves the rods at the last iterate (the caller throws StaticsFailure).
  SceneEquilibrium statics(double t);
  std::string statics_summary(const SceneEquilibrium& eq) const;
  // The sensitivity of rod `rod`'s equilibrium to material keys (scene_statics_sensitivity) at
  // the last converged statics(). Throws StaticsFailure when none was solved, or the state has
  // changed since (a step, another solve that failed); SceneError for a bad parameter.
  std::vector<StaticSensitivity> statics_sensitivity(int rod,
                                                     const std::vector<std::string>& parameters);

  const Scene& scene() const { return *scene_; }
  const World& world() const { return scene_->world; }
  // Rod by name; throws std::out_of_range naming the rods there are.
  int rod_index(const std::string& name) const;
  const Rod& rod(int index) const;

  // Events since load, the last kMaxEvents of each: the guard's, and all the driver's (the
  // guard's again, took hold, let go, ...).
  static constexpr size_t kMaxEvents = 10000;
  const std::vector<GuardEvent>& guard_events() const { return guard_events_; }
  const std::vector<SimulationEvent>& events() const { return events_; }
  long steps() const { return steps_; }

 private:
  SceneSimulation(Scene scene, const RunOptions& options);
  void take_events();

  std::unique_ptr<Scene> scene_;  // stays put: the driver steps its world
  RunOptions options_;
  Simulation sim_;
  std::vector<GuardEvent> guard_events_;
  std::vector<SimulationEvent> events_;
  long steps_ = 0;
  // The last converged equilibrium: its time and every rod's node positions and frames then.
  bool equilibrium_ = false;
  double equilibrium_time_ = 0.0;
  std::vector<std::vector<Vec3>> equilibrium_x_;
  std::vector<std::vector<Quat>> equilibrium_q_;
};

}  // namespace corde::python
