#include "scene_simulation.h"

#include <cmath>
#include <cstdio>

namespace corde::python {

std::string scene_error_message(const std::string& source, const std::string& what) {
  return what.rfind(source, 0) == 0 ? what : source + ": " + what;
}

SceneSimulation::SceneSimulation(Scene scene, const RunOptions& options)
    : scene_(std::make_unique<Scene>(std::move(scene))), options_(options), sim_(options.guard) {
  try {
    drive_scene(&sim_, scene_.get());
  } catch (const SceneError& e) {
    throw SceneError(scene_error_message(scene_->source, e.what()));
  }
}

std::unique_ptr<SceneSimulation> SceneSimulation::load(const std::string& path,
                                                       const std::vector<std::string>& overrides,
                                                       const RunOptions& options) {
  Scene scene;
  try {
    scene = load_scene(path, overrides);
  } catch (const SceneError& e) {
    throw SceneError(scene_error_message(path, e.what()));
  }
  return std::unique_ptr<SceneSimulation>(new SceneSimulation(std::move(scene), options));
}

std::unique_ptr<SceneSimulation> SceneSimulation::parse(const std::string& yaml,
                                                        const std::vector<std::string>& overrides,
                                                        const std::string& source,
                                                        const RunOptions& options) {
  Scene scene;
  try {
    scene = parse_scene(yaml, overrides, source);
  } catch (const SceneError& e) {
    throw SceneError(scene_error_message(source, e.what()));
  }
  return std::unique_ptr<SceneSimulation>(new SceneSimulation(std::move(scene), options));
}

void SceneSimulation::take_events() {
  for (SimulationEvent& e : sim_.take_events()) {
    if (e.kind == SimulationEvent::Kind::kGuard) guard_events_.push_back(e.guard);
    events_.push_back(std::move(e));
  }
  // Bounded: the most recent kMaxEvents of each.
  if (guard_events_.size() > kMaxEvents)
    guard_events_.erase(guard_events_.begin(), guard_events_.end() - kMaxEvents);
  if (events_.size() > kMaxEvents) events_.erase(events_.begin(), events_.end() - kMaxEvents);
}

void SceneSimulation::step(long n) {
  if (n < 0) throw std::invalid_argument("step: n must be >= 0, got " + std::to_string(n));
  const World& world = scene_->world;
  const double t0 = world.time();
  bool good = sim_.advance(n);
  // Checked before the state is shown, as corde_run does before each frame.
  if (good && options_.guard.enabled) good = sim_.settle();
  take_events();
  const double h = world.time_step;
  steps_ += h > 0.0 ? std::lround((world.time() - t0) / h) : n;
  if (!good) {
    const StepGuard& guard = sim_.guard();
    char buf[160];
    std::snprintf(buf, sizeof buf,
                  "the stability guard could not recover (every retry failed); the run stopped "
                  "at its last good state, t = %.6g s: ",
                  world.time());
    throw GuardFailure(buf + (guard.events().empty() ? std::string("the guard gave up")
                                                     : guard.events().back().message()));
  }
  const std::string problem = run_problem(world, options_);
  if (!problem.empty()) {
    char buf[160];
    std::snprintf(buf, sizeof buf, "the run blew up at step %ld (t = %.6g s): ", steps_,
                  world.time());
    throw RunawayFailure(buf + problem + "; try a smaller time step");
  }
}

void SceneSimulation::run(double duration) {
  const double h = scene_->world.time_step;
  if (duration < 0.0) duration = scene_->duration;
  // As run_scene: in double first, duration / h can exceed any integer.
  const double n = std::ceil(duration / h - 1e-9);
  if (!(h > 0.0) || !(n <= options_.max_steps)) {
    char buf[200];
    std::snprintf(buf, sizeof buf,
                  "duration %g s at time_step %g s needs %g steps, more than the limit of %g "
                  "(max_steps)",
                  duration, h, n, options_.max_steps);
    throw SceneError(buf);
  }
  step(std::max(0L, static_cast<long>(n)));
}

SceneEquilibrium SceneSimulation::statics(double t) {
  SceneEquilibrium eq;
  try {
    eq = solve_scene_statics(scene_.get(), t);
  } catch (const SceneError& e) {
    throw SceneError(scene_error_message(scene_->source, e.what()));
  }
  sim_.restart_guard();
  equilibrium_ = eq.ok;
  equilibrium_time_ = t;
  equilibrium_x_.clear();
  equilibrium_q_.clear();
  for (const Rod& r : scene_->world.rods()) {
    equilibrium_x_.push_back(r.positions());
    equilibrium_q_.push_back(r.orientations());
  }
  return eq;
}

std::vector<StaticSensitivity> SceneSimulation::statics_sensitivity(
    int index, const std::vector<std::string>& parameters) {
  const Rod& r = rod(index);
  if (index < 0) index += static_cast<int>(scene_->world.rods().size());
  bool same = equilibrium_;
  for (size_t i = 0; same && i < equilibrium_x_.size(); ++i) {
    const Rod& ri = scene_->world.rods()[i];
    same = ri.positions() == equilibrium_x_[i];
    for (size_t s = 0; same && s < equilibrium_q_[i].size(); ++s)
      same = ri.orientations()[s].coeffs() == equilibrium_q_[i][s].coeffs();
  }
  if (!same)
    throw StaticsFailure(
        "statics sensitivity: no static equilibrium to differentiate: call statics() first (and "
        "after any step: the sensitivity is that of the equilibrium the rods are at)");
  try {
    return scene_statics_sensitivity(scene_.get(), r.name(), equilibrium_time_, parameters);
  } catch (const SceneError& e) {
    throw SceneError(scene_error_message(scene_->source, e.what()));
  }
}

std::string SceneSimulation::statics_summary(const SceneEquilibrium& eq) const {
  return corde::statics_summary(*scene_, eq);
}

int SceneSimulation::rod_index(const std::string& name) const {
  const auto& rods = scene_->world.rods();
  std::string names;
  for (size_t i = 0; i < rods.size(); ++i) {
    if (rods[i].name() == name) return static_cast<int>(i);
    names += (names.empty() ? "'" : ", '") + rods[i].name() + "'";
  }
  throw std::out_of_range("no rod named '" + name + "' (rods: " + names + ")");
}

const Rod& SceneSimulation::rod(int index) const {
  const auto& rods = scene_->world.rods();
  const int n = static_cast<int>(rods.size());
  if (index < 0) index += n;
  if (index < 0 || index >= n)
    throw std::out_of_range("rod index " + std::to_string(index) + " out of range (" +
                            std::to_string(n) + " rods)");
  return rods[index];
}

}  // namespace corde::python
