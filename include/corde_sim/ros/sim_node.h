// corde_sim_node's adapter: ROS parameters, topics, tf and services in, calls on the rod library,
// tf frames, markers, state and diagnostics out. No physics here.
//
// Every input reaches the simulation as a command of the node's one queue (command_queue.h, which
// states the threading model): only the loop thread applies them, between batches of steps, so
// nothing in the library is touched concurrently. The time model (the three time sources, the
// pacing and the mapping between simulation time and ROS time) is NodeClock (node_clock.h).
//
// SimNode holds the simulation driver and the loop (inputs, steps, outputs); its parts, each in
// its own file: NodeInputs (topics, tf, reconfigure), SceneInstall (scene, robot, grasps made),
// NodeServices (the services), NodeOutputs (topics out, diagnostics), with NodeStats between them.
#pragma once

#include <geometry_msgs/Pose.h>
#include <geometry_msgs/TransformStamped.h>
#include <ros/ros.h>

#include <Eigen/Geometry>
#include <atomic>
#include <map>
#include <string>

#include "corde_sim/grasp/grasp.h"
#include "corde_sim/grasp/grasp_set.h"
#include "corde_sim/ros/command_queue.h"
#include "corde_sim/ros/configure.h"
#include "corde_sim/ros/node_clock.h"
#include "corde_sim/ros/node_inputs.h"
#include "corde_sim/ros/node_obstacles.h"
#include "corde_sim/ros/node_outputs.h"
#include "corde_sim/ros/node_params.h"
#include "corde_sim/ros/node_services.h"
#include "corde_sim/ros/node_stats.h"
#include "corde_sim/ros/scene_install.h"
#include "corde_sim/simulation/simulation.h"
#include "corde_sim/stability/step_guard.h"

namespace corde_sim {

// The ROS side of a grasp: where its holder pose comes from and its topics. The grasp itself
// (segment, holder motion, wrench, reaction) lives in the library's GraspSet.
struct GraspWiring {
  GraspSource source = GraspSource::kTopic;
  std::string frame;        // followed tf frame (kTf)
  bool attached = true;     // kTf: false until the frame was first seen (the segment stays put)
  bool has_offset = false;  // the offset and snap of ~grasps/<name> (GraspSourceParam)
  Eigen::Isometry3d offset = Eigen::Isometry3d::Identity();
  bool snap = false;
  int marker_id = 0;
  double last_input_time = -1.0;  // ROS time of the last pose input (s), for its interval
  // A scene grasp with keyframes (GraspSpec::motion), grasp_time or release_time is "scripted":
  // the simulation driver takes hold and lets go at those times and moves its holder along the
  // keyframes (corde::ScriptDrive::kHolder) until the grasp's first input (a pose, its tf frame,
  // ~grasp, ~release). `scripted` mirrors the driver's state for the node's replies.
  bool scripted = false;
  corde::GraspSpec script_spec;
  ros::Subscriber pose_sub, wrench_sub, twist_sub;
  ros::Publisher reaction_pub;
  ros::Subscriber grip_sub;  // grasps/<name>/grip (grip_input.h)
  ros::Publisher slip_pub;   // grasps/<name>/slip: a friction grasp's slip velocity (m/s)
};

class SimNode {
 public:
  // Reads and validates parameters, loads the scene and sets up ROS interfaces. Throws
  // std::invalid_argument (bad parameter) or corde::SceneError (bad scene).
  SimNode(const ros::NodeHandle& nh, const ros::NodeHandle& pnh);
  // Releases callers still waiting for a command, then stops the service threads.
  ~SimNode();
  // Runs until shutdown (or for ~benchmark seconds). Returns the process exit code.
  int run();

  // Advances the world by n steps with the current inputs; returns steps done before `deadline`
  // (steady-clock seconds). Public for the benchmark and tests of the adapter.
  long run_steps(long n, double deadline);
  double sim_time() const { return time_offset_ + world_.time(); }
  // The time model: stamps (stamp() below) and its inverse, clock().sim_time_at(ros seconds),
  // the simulation time an input's header stamp stands for.
  const NodeClock& clock() const { return clock_; }
  const corde::World& world() const { return world_; }

 private:
  friend class NodeInputs;
  friend class NodeObstacles;
  friend class NodeOutputs;
  friend class NodeServices;
  friend class SceneInstall;

  // The loop's side of the command queue: applies every waiting command, oldest first.
  void drain_commands();
  // No command is applied from now on: callers still waiting (a ~step included) return.
  void close_commands();
  // A scripted grasp took hold or let go, or a grasp was made or let go: the layout follows.
  void refresh_if_grasps_changed();
  void check_holders_and_strain();
  void advance(double now);
  // While paused: runs steps queued by ~step in batches, outputs between them.
  void run_queued_steps(double now);
  // The stability guard (corde::StepGuard) checks the state after each batch of steps (and every
  // 64 steps within), rolls back and retries; this reports its new events (log, diagnostics) and
  // returns false while it has given up (the world then stays at its last good state).
  bool settle_guard();
  // Reports the driver's events: the guard's (log, diagnostics) and the scripts' (layout).
  void report_guard_events();
  // A new world (start-up, reset, configure): the guard starts over from it. Returns what to add
  // to the service's message when the guard had given up before ("" otherwise).
  std::string restart_guard();
  // A changed state (reset, configure, grasp) gets a later stamp than anything published before,
  // and is stamped at the ROS time of the change (NodeClock::anchor).
  void bump_time();
  // The current state's stamp: the ROS time of simulation time sim_time() (NodeClock::stamp_ns).
  ros::Time stamp() const;
  // The clock's view of an external /clock before the steps: its start, its jumps (logged).
  void observe_clock(double now);
  // The state is stamped at the current ROS time from now on (NodeClock::anchor).
  void anchor_clock();
  int benchmark_report(double wall, double cpu, unsigned long steps, double sim, double step_cpu);

  ros::NodeHandle nh_, pnh_;
  NodeParams params_;
  // The simulation driver: world, guard, grasps, scripts, pause and ~step's queued steps, the
  // holder limits (configuration, outside the guard's snapshot) and the commands since the
  // snapshot (replayed after a rollback); the node feeds it from the command queue and reads its
  // state.
  corde::Simulation sim_;
  corde::World& world_ = sim_.world();
  corde::GraspSet& grasps_ = sim_.grasps();
  corde::StepGuard& guard_ = sim_.guard();
  std::map<std::string, GraspWiring> wiring_;
  bool layout_changed_ = false;  // a scripted grasp took hold or let go: refresh_layout() due
  struct HolderWarning {
    bool lagging = false;
    double last_wall = -1e300;  // wall_seconds() of the last warning
  };
  std::map<std::string, HolderWarning> holder_warnings_;  // by grasp name
  // The one way in (command_queue.h); the loop applies it in drain_commands().
  CommandQueue commands_;
  std::atomic<bool> loop_running_{false};  // run() drains the queue: callers may wait on it
  SimSettings settings_;
  double time_offset_ = 0.0;     // node simulation time = time_offset_ + world_.time()
  NodeClock clock_;              // pacing and stamps (node_clock.h)
  bool waiting_logged_ = false;  // "waiting for /clock" said once
  NodeStats stats_;

  // The parts (after what they use).
  SceneInstall scene_{this};
  NodeInputs inputs_{this};
  NodeOutputs outputs_{this};
  NodeServices services_{this};
  NodeObstacles obstacles_{this};  // added at run time (~add_obstacle)
};

// A tf transform as an isometry (rotation normalised).
Eigen::Isometry3d to_eigen(const geometry_msgs::TransformStamped& t);
// An isometry as a pose message.
geometry_msgs::Pose to_pose_msg(const Eigen::Isometry3d& pose);

// Steady (monotonic) wall clock in seconds.
double wall_seconds();

}  // namespace corde_sim
