// A stability guard around World::step: it advances a world and checks it every few steps for
// non-finite values, runaway speeds, strains beyond physical limits and energy that grows without
// work done on the rods. A state that fails is never kept: the world goes back to the last state
// that passed (a snapshot, a copy of the world) and the steps since are redone with half the time
// step, a few times, and for an explicit integrator with the implicit one when halving cannot
// help or would cost too many substeps. After a while of good steps the user's step and method
// are tried again. Every detection and action is an event; a failure that no retry cures leaves
// the world at its last good state and the guard reports it until reset (docs/stability_guard.md).
#pragma once

#include <algorithm>
#include <functional>
#include <string>
#include <vector>

#include "corde_sim/stability/state_checks.h"
#include "corde_sim/world/world.h"

namespace corde {

struct GuardSettings {
  bool enabled = true;
  // Substeps between checks; every check that passes takes a snapshot. A blow-up grows
  // geometrically, so a few tens of steps between checks lose nothing but a short replay, and
  // keep the cost (a pass over the state, one energy evaluation and one copy of the world per
  // check, about 1.5 steps' worth) to a few percent of the steps (BM_GuardOverhead).
  int check_every = 64;
  // The state checks (stability/state_checks.h, docs/stability_guard.md): finite, unit
  // quaternions, speeds, stretch, shear and bend (off by default), penetration.
  StateLimits limits;
  // Energy growth without work: over the steps since the last snapshot, the rise of the total
  // energy (kinetic, elastic, gravity) may not exceed the work the drives, clamps, loads,
  // external forces and contacts (moving obstacles, push-out) can have done, counted as the sum
  // of |power| h, plus energy_tolerance times the rods' kinetic and elastic energy at the
  // snapshot plus energy_floor times m g L (each rod's weight times its length), which covers
  // the integrators' bounded energy errors.
  double energy_tolerance = 0.1;
  double energy_floor = 1e-3;
  // Retries: halve the step up to max_halvings times (each cures the failure only if it persists
  // through a replay). An explicit method switches to the implicit one (at the user's step)
  // when that is exhausted, or at once when the stability estimate says the halved steps would
  // still be above the explicit limit.
  int max_halvings = 3;
  bool allow_implicit = true;
  // Seconds of simulated time without an event before the user's step and method are tried
  // again (doubled each time that trial fails).
  double relax_after = 0.5;
};

struct GuardEvent {
  enum class Kind {
    // The state checks (StateCheck, limits in GuardSettings::limits):
    kNonFinite,       // a NaN or infinity in the state (or the step threw, or did not converge)
    kQuaternion,      // a quaternion off unit norm
    kSpeed,           // a node or segment beyond max_speed / max_angular_speed
    kStretch,         // a segment beyond max_stretch or max_compression
    kShear,           // a frame beyond max_shear_angle off its tangent
    kBend,            // an element turned beyond max_bend_angle from its rest shape
    kSpecificEnergy,  // a rod beyond max_specific_energy (off by default)
    kPenetration,     // a rod deeper than max_penetration in a static obstacle or another rod
    // The guard's own:
    kEnergy,         // energy grew more than the work done allows
    kRestored,       // back to the user's step and method after good steps
    kUnrecoverable,  // no retry helped: the world stays at its last good state
  };
  enum class Action { kNone, kHalveStep, kImplicit, kGiveUp, kRestore };
  Kind kind = Kind::kNonFinite;
  Action action = Action::kNone;
  double time = 0.0;       // s, the world's time when it was detected
  double rollback_to = 0;  // s, the snapshot the world went back to
  std::string rod;         // "" when not about one rod
  int item = -1;           // node, segment or element index (-1: the whole rod or world)
  std::string detail;      // what was measured against which limit
  double time_step = 0.0;  // the step (s) and method the guard continued with
  Integrator integrator = kDefaultIntegrator;
  // One line: "t = 0.0123 s: rod 'cable' segment 4 stretched by 1.3 (limit 1): rolled back to
  // t = 0.0120 s, retrying with time step 5e-05 s (split_rotation)".
  std::string message() const;
};

const char* guard_event_kind_name(GuardEvent::Kind kind);

// The first problem found in a state (found false when none).
struct GuardProblem {
  bool found = false;
  GuardEvent::Kind kind = GuardEvent::Kind::kNonFinite;
  std::string rod;
  int item = -1;
  std::string detail;
};

class StepGuard {
 public:
  // One step of world->time_step from world->time(), the caller's inputs included (grasps,
  // scripted holders, robot links). Default: world->step().
  using StepFn = std::function<void(World*)>;

  explicit StepGuard(const GuardSettings& settings = GuardSettings()) : settings_(settings) {}
  const GuardSettings& settings() const { return settings_; }
  void set_settings(const GuardSettings& s) { settings_ = s; }

  // State beside the world that must go back with it (a node's grasp holders): saved at every
  // snapshot, restored at every rollback.
  void set_hooks(std::function<void()> save, std::function<void()> restore) {
    save_ = std::move(save);
    restore_ = std::move(restore);
  }

  // Starts over from this world: its time step and integrator are the user's, its state the
  // first snapshot (a state that fails the checks is accepted as given). Clears the failure and
  // the event counts (not the event list: clear_events()).
  void reset(const World& world);

  // Advances the world by n of the user's steps (each 2^k substeps while the step is halved).
  // Returns false when a failure could not be cured: the world is then at the last good state
  // and stays there (every further call returns false at once) until reset(). The world runs
  // the guard's (maybe reduced) step and method inside the call and shows the user's between
  // calls; a change of world->time_step or world->integrator made from outside is taken as the
  // user's new setting.
  bool step(World* world, long n = 1, const StepFn& fn = StepFn());
  // Checks the state now (steps since the last check are otherwise checked only every
  // check_every substeps) and recovers as step() does: call before showing or publishing it.
  bool settle(World* world, const StepFn& fn = StepFn());

  // The caller changed the state between steps (a grasp made or let go): it becomes the state
  // to go back to.
  void mark_good(const World& world) {
    if (have_snap_ && !failed_) snapshot(world);
  }

  bool failed() const { return failed_; }
  // The user's setting, and what the guard runs now (they differ while it recovers).
  double user_time_step() const { return user_h_; }
  Integrator user_integrator() const { return user_integrator_; }
  double time_step() const { return h_; }
  Integrator integrator() const { return integrator_; }
  bool reduced() const { return h_ != user_h_ || integrator_ != user_integrator_; }

  // Every event since construction or clear_events(), oldest first (at most 1000: then the
  // oldest go), and how many there were of each action.
  const std::vector<GuardEvent>& events() const { return events_; }
  void clear_events() { events_.clear(); }
  // Events pushed since construction (events() keeps the last 1000 of them): a caller that saw
  // `seen` of them finds the new ones at the end of events().
  long events_total() const { return events_total_; }
  // The events pushed after the first `seen`, oldest first (at most the last 1000).
  std::vector<GuardEvent> events_since(long seen) const {
    const long n = std::min<long>(events_total_ - seen, static_cast<long>(events_.size()));
    return n > 0 ? std::vector<GuardEvent>(events_.end() - n, events_.end())
                 : std::vector<GuardEvent>();
  }
  long detections() const { return detections_; }
  long rollbacks() const { return rollbacks_; }
  // Work bound of the current window, and summed over the run since reset() (the windows kept
  // and the current one; for tests and diagnostics).
  double window_work() const { return work_; }
  double total_work() const { return kept_work_ + work_; }

 private:
  bool advance(World* world, long n, bool check_at_end, const StepFn& fn);
  bool run(World* world, long n, bool check_at_end, const StepFn& fn);
  void sync_user_settings(const World& world);
  // Energies: the state's, when the check just computed them.
  void snapshot(const World& world, const WorldEnergies* energies = nullptr);
  void rollback(World* world);
  bool reduce(const World& world, const GuardProblem& p, double t_fail);
  GuardProblem check(const World& world, WorldEnergies* energies) const;
  void add_step_work(const World& world, double h);
  void push_event(const GuardEvent& e);
  void apply(World* world) const {
    world->time_step = h_;
    world->integrator = integrator_;
  }

  GuardSettings settings_;
  std::function<void()> save_, restore_;
  World snap_;
  bool have_snap_ = false;
  bool failed_ = false;
  double user_h_ = 0.0, h_ = 0.0;
  Integrator user_integrator_ = kDefaultIntegrator, integrator_ = kDefaultIntegrator;
  int halvings_ = 0;      // of the step now run, against the user's (or the implicit's) step
  long since_snap_ = 0;   // user steps since the snapshot
  long since_check_ = 0;  // substeps since the last check
  double snap_energy_ = 0.0, snap_scale_ = 0.0, work_ = 0.0;
  double kept_work_ = 0.0;    // work bound of the windows that passed since reset()
  double good_since_ = 0.0;   // world time of the last event
  double relax_after_ = 0.0;  // current wait before trying the user's setting again
  bool trial_ = false;        // running the user's setting again on trial
  double saved_h_ = 0.0;      // the reduced setting to go back to if the trial fails
  Integrator saved_integrator_ = kDefaultIntegrator;
  int saved_halvings_ = 0;
  double mgl_ = 0.0;  // sum over rods of m max(|g|, 1) L, for energy_floor
  std::vector<GuardEvent> events_;
  long detections_ = 0, rollbacks_ = 0, events_total_ = 0;
};

}  // namespace corde
