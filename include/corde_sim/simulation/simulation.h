// The simulation driver (no ROS): a world with its stability guard, grasps, scene scripts,
// time-stamped commands and moving obstacles, advanced step by step. corde_run and the ROS node
// both step through it, so the loop that feeds inputs to a world exists once and is tested
// without a ROS master.
//
// Per step from t (of the guard's step h): the commands due (time <= t + h/2) are applied in time
// order, the scripts take hold, let go and move their holders, the grasps move their holders
// (GraspSet::before_step), the obstacle mover poses the moving obstacles, World::step() steps,
// the grasps accumulate their reactions (GraspSet::after_step) and the step observer sees the
// world. The guard may roll the world back to its last snapshot: the grasps, the scripts and the
// commands go back with it (commands applied since the snapshot are applied again at the same
// steps), while configuration (the holder limits) stays as last set: a rollback never reverts it.
#pragma once

#include <Eigen/Geometry>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "corde_sim/grasp/grasp.h"
#include "corde_sim/grasp/grasp_set.h"
#include "corde_sim/grasp/holder.h"
#include "corde_sim/stability/step_guard.h"
#include "corde_sim/world/world.h"

namespace corde {

// An input to the simulation, applied before the first step that starts within half a step of
// `time` (world time, s); a time already past applies before the next step.
struct Command {
  enum class Kind {
    kGoal,       // grasp's holder to `pose`, reached `duration` s later (GraspSet::set_goal), or,
                 // `stamped`, the pose for world time `stamp` of a stream (GraspSet::add_sample)
    kWrench,     // grasp's applied wrench (world frame, at the held segment's midpoint)
    kTwistRate,  // grasp's twist rate about the held segment's tangent (rad/s)
    kRelease,    // grasp lets go (its script, if any, ends)
    kGripForce,  // a friction grasp's grip force `grip_force` (N; GraspSet::set_grip_force)
  };
  Kind kind = Kind::kGoal;
  double time = 0.0;
  std::string grasp;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  double duration = 0.0;
  bool stamped = false;
  double stamp = 0.0;  // stamped: the world time the pose is for
  Vec3 force = Vec3::Zero(), torque = Vec3::Zero();
  double rate = 0.0;
  double grip_force = 0.0;

  static Command goal(double time, const std::string& grasp, const Eigen::Isometry3d& pose,
                      double duration);
  // A pose of a stream for world time `stamp`: the holder's reference interpolates the stream's
  // poses by their stamps (HolderMotion::add_sample).
  static Command sample(double time, const std::string& grasp, const Eigen::Isometry3d& pose,
                        double stamp);
  static Command wrench(double time, const std::string& grasp, const Vec3& force,
                        const Vec3& torque);
  static Command twist_rate(double time, const std::string& grasp, double rate);
  static Command release(double time, const std::string& grasp);
  // Throws std::invalid_argument for a force that is negative or not finite.
  static Command grip(double time, const std::string& grasp, double force);
};

// What happened while advancing, for the caller to report (take_events()).
struct SimulationEvent {
  enum class Kind {
    kGuard,        // the guard detected, acted or gave up (`guard`)
    kTookHold,     // a script took hold of its segment
    kLetGo,        // a script (or a kRelease command) let go, or the cable slid out of a friction
                   // grasp past its start or end (`text` says which)
    kCannotHold,   // a script could not take hold (`text` says why); it tries again next step
    kScriptEnded,  // a goal or release command ended a grasp's script (not again on a replay)
    kStalled,      // a grasp's holder stalled at its material's strain limit (`text` says where)
  };
  Kind kind = Kind::kGuard;
  double time = 0.0;  // world time (s)
  std::string grasp;  // "" for guard events
  std::string text;
  GuardEvent guard;
};

// How a scene grasp's script (keyframes, grasp_time, release_time) drives its segment.
enum class ScriptDrive {
  // The segment is held exactly on the keyframes (corde_run): hold() with the keyframes' pose at
  // the end of each step; no holder, no limits, not in grasps().
  kExact,
  // The grasp is one of grasps(): each step sets its holder's goal to the keyframes' pose at the
  // step's end, reached then (the holder limits apply); the first goal or release input for it
  // ends the script (the ROS node).
  kHolder,
};

class Simulation {
 public:
  // Moves moving obstacles (a robot's links) before each step of h seconds; allocates nothing.
  using ObstacleMover = std::function<void(World* world, double h)>;
  // Sees the world after each step (inside the guard: a replay shows the steps again).
  using StepObserver = std::function<void(const World& world)>;

  explicit Simulation(const GuardSettings& guard = GuardSettings());
  Simulation(const Simulation&) = delete;
  Simulation& operator=(const Simulation&) = delete;

  // Starts over with this world: no grasps, scripts or commands; the guard restarts from it.
  void install(World world);
  // The same with a world the caller keeps (and may read or change between steps); it must
  // outlive the driver's use of it (corde_run steps the scene's own world).
  void attach(World* world);
  World& world() { return *world_; }
  const World& world() const { return *world_; }
  // Grasps may be added, attached or released between steps (call mark_good() after, so that a
  // rollback does not undo the change); inputs to them go through submit().
  GraspSet& grasps() { return grasps_; }
  const GraspSet& grasps() const { return grasps_; }
  StepGuard& guard() { return guard_; }
  const StepGuard& guard() const { return guard_; }

  // Scene grasp `spec` follows its script. kExact: the script takes hold itself (now, if
  // grasp_holds() at the world's time). kHolder: grasps() must hold a grasp of that name made
  // now (released here if the script takes hold later).
  void add_script(const GraspSpec& spec, ScriptDrive drive);
  // Whether grasp `name` is still driven by its script, and whether that script has not taken
  // hold yet and still will (before its release time).
  bool scripted(const std::string& name) const;
  bool waiting_to_take_hold(const std::string& name) const;
  // Ends grasp `name`'s script now (its holder stays where it is); the state becomes the one to
  // go back to. Returns whether it had one.
  bool end_script(const std::string& name);

  // Configuration, outside the guard's snapshot: applies from the next step and survives
  // rollbacks.
  void set_holder_limits(const HolderLimits& limits) { holder_limits_ = limits; }
  const HolderLimits& holder_limits() const { return holder_limits_; }
  void set_obstacle_mover(ObstacleMover mover) { mover_ = std::move(mover); }
  void set_step_observer(StepObserver observer) { observer_ = std::move(observer); }

  // Queues a command (kept in time order; a later command of the same kind for the same grasp
  // at the same time replaces a waiting one, so the queue stays bounded while the time stands
  // still).
  void submit(Command c);
  size_t pending_commands() const { return commands_.size() - next_; }
  // Applies now, between steps, the waiting commands of the world's time (those the next step
  // would apply first, in the same order): a caller that must answer at once (the node's
  // ~release) sees their effect. They count as applied since the snapshot, so a rollback replays
  // them at the step starting at their time, as if the next step had applied them.
  void apply_due();

  // Paused, advance() runs only steps queued by queue_steps(); resuming drops those.
  void set_paused(bool paused);
  bool paused() const { return paused_; }
  void queue_steps(long n) { queued_steps_ += n; }
  long queued_steps() const { return queued_steps_; }
  // Drops the queued steps (a reset, or the guard stopped); returns how many there were.
  long drop_queued_steps() {
    const long n = queued_steps_;
    queued_steps_ = 0;
    return n;
  }

  // Advances by up to n of the user's steps (paused: at most the queued ones). Returns false when
  // the guard has given up: the world is then at its last good state and stays there until
  // install() or restart_guard().
  bool advance(long n);
  // Advances to the step nearest world time t (no step when t is within half a step).
  bool advance_until(double t);
  // Has the guard check the state now (before showing or publishing it).
  bool settle();
  // The world was changed from outside (a configure): the guard starts over from it.
  void restart_guard();
  // The state was changed between steps from outside (a grasp made or let go): it becomes the
  // state to go back to.
  void mark_good() { guard_.mark_good(*world_); }

  // The events since the last call, oldest first (at most the last 1000). A replay after a
  // rollback reports the scripts' take-holds and let-gos again.
  std::vector<SimulationEvent> take_events();

 private:
  struct Script {  // what goes back with the world at a rollback
    bool active = true;
    bool holding = false;
    bool warned = false;  // kCannotHold reported since it last held
    Grasp grasp;          // kExact
    Eigen::Isometry3d start = Eigen::Isometry3d::Identity();
    Eigen::Isometry3d offset_inv = Eigen::Isometry3d::Identity();  // kHolder: holder = pose * it
    std::shared_ptr<const Motion> motion;
  };
  void step_once(World* w);
  void apply(World* w, const Command& c, bool first);
  // Applies the waiting commands whose time is at most t, in order.
  void apply_until(World* w, double t);
  void drive_scripts(World* w, double t, double h);
  void take_hold_exact(World* w, size_t k);
  void end_script_at(size_t k, double time, bool report);
  int script_index(const std::string& name) const;
  void event(SimulationEvent::Kind kind, double time, const std::string& grasp,
             std::string text = std::string());
  void take_guard_events();
  void report_stalls(const World& w, double t);
  void report_slid_out(double t);

  World own_;
  World* world_ = &own_;
  GraspSet grasps_, saved_grasps_;
  StepGuard guard_;
  StepGuard::StepFn step_fn_;
  HolderLimits holder_limits_;
  std::vector<GraspSpec> specs_;  // the scripts' specs and drives, fixed from add_script()
  std::vector<ScriptDrive> drives_;
  std::vector<int> rods_;  // kExact: the rod index
  std::vector<Script> scripts_, saved_scripts_;
  std::vector<Command> commands_;  // time order; [0, next_) applied since the snapshot
  size_t next_ = 0;
  size_t applied_high_ = 0;  // commands_[0, applied_high_) were applied once (events once)
  ObstacleMover mover_;
  StepObserver observer_;
  bool paused_ = false;
  long queued_steps_ = 0;
  long guard_events_seen_ = 0;
  std::vector<SimulationEvent> events_;
};

}  // namespace corde
