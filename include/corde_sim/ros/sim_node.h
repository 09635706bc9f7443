// corde_sim_node's adapter: ROS parameters, topics, tf and services in, calls on the rod library,
// tf frames, markers, state and diagnostics out. No physics here.
//
// Every input reaches the simulation as a command of the node's one queue (command_queue.h, which
// states the threading model): only the loop thread applies them, between batches of steps, so
// nothing in the library is touched concurrently. The loop is paced on the steady wall clock,
// never on ROS time, so it also works when the node itself publishes /clock.
#pragma once

#include <diagnostic_updater/diagnostic_updater.h>
#include <dynamic_reconfigure/server.h>
#include <geometry_msgs/PoseStamped.h>
#include <geometry_msgs/WrenchStamped.h>
#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <ros/spinner.h>
#include <std_msgs/Float64.h>
#include <std_srvs/SetBool.h>
#include <tf2_msgs/TFMessage.h>
#include <tf2_ros/buffer.h>
#include <visualization_msgs/MarkerArray.h>

#include <atomic>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include "corde_sim/Configure.h"
#include "corde_sim/Grasp.h"
#include "corde_sim/ListGrasps.h"
#include "corde_sim/NodeConfig.h"
#include "corde_sim/Release.h"
#include "corde_sim/Reset.h"
#include "corde_sim/Step.h"
#include "corde_sim/WorldState.h"
#include "corde_sim/grasp/grasp.h"
#include "corde_sim/grasp/grasp_set.h"
#include "corde_sim/ros/command_queue.h"
#include "corde_sim/ros/configure.h"
#include "corde_sim/ros/input_events.h"
#include "corde_sim/ros/node_params.h"
#include "corde_sim/ros/output_schedule.h"
#include "corde_sim/ros/outputs.h"
#include "corde_sim/ros/pacer.h"
#include "corde_sim/ros/reconfigure_input.h"
#include "corde_sim/ros/robot_obstacles.h"
#include "corde_sim/ros/service_threads.h"
#include "corde_sim/ros/tf_input.h"
#include "corde_sim/scene/scene.h"
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
  const corde::World& world() const { return world_; }

 private:
  // Scene and grasps. install_scene returns "" or why the scene cannot be used (then nothing
  // changed).
  std::string install_scene(corde::Scene scene, const std::string& path);
  std::string add_grasp(const corde::GraspSpec& spec, GraspSource source, const std::string& frame,
                        bool from_scene, int* segment);
  void wire_grasp(const std::string& name, GraspWiring* w);
  void update_tf_holders();
  // Robot collision (sim_node_robot.cpp): reads the URDF (throws std::invalid_argument naming the
  // parameter, file and element), puts the robot's seen links into the world's obstacles (after
  // a new world: start-up, reset), and follows the links' tf frames between batches of steps.
  void load_robot();
  void install_robot();
  void update_robot();
  // An input for grasp `name` arrived, or it was let go (`what`: "grasp '<name>' <what>"): its
  // keyframes stop moving it (logged once, at INFO); the state becomes the one to go back to.
  void end_script(const std::string& name, const char* what);
  // Whether grasp `name` is scripted, not held and its script will still take hold (before its
  // grasp_time, or unable to take hold yet): not one its script already let go.
  bool waiting_to_take_hold(const std::string& name) const;
  // A released grasp made through ~grasp (not the scene's), without a wrench: its topics and its
  // entry go. Returns whether it did.
  bool forget_grasp(const std::string& name);
  void refresh_layout();
  void refresh_if_grasps_changed();
  // The loop's side of the command queue: applies every waiting command, oldest first.
  void drain_commands();
  // No command is applied from now on: callers still waiting (a ~step included) return.
  void close_commands();
  // (loop) A grasp input, checked against its grasp (held, stamp order, tf source), becomes a
  // command of the driver at the current world time (corde::Simulation::submit).
  void apply_input(const InputEvent& e);
  // Runs `fn` in the loop thread and waits (a service thread); false when the node shuts down.
  bool in_loop(const std::function<void()>& fn);
  void check_holders_and_strain();

  // Inputs.
  void on_pose(const std::string& name, const geometry_msgs::PoseStampedConstPtr& msg);
  void on_wrench(const std::string& name, const geometry_msgs::WrenchStampedConstPtr& msg);
  void on_twist_rate(const std::string& name, const std_msgs::Float64ConstPtr& msg);
  bool lookup_world(const std::string& frame, const ros::Time& stamp, Eigen::Isometry3d* out,
                    std::string* error) const;
  bool own_frame(const std::string& frame, Eigen::Isometry3d* out) const;
  std::string check_workspace(const Eigen::Vector3d& p) const;
  std::string resolve_scene(const std::string& path, std::string* error) const;
  double ros_to_sim_interval(double ros_seconds) const;

  // Services. Each callback runs on a service thread: the part that needs no simulation state
  // (reading a scene, a trial step of a candidate world) runs there, the rest in the loop.
  bool on_reset(Reset::Request& req, Reset::Response& res);
  bool on_configure(Configure::Request& req, Configure::Response& res);
  void reset(Reset::Request& req, Reset::Response& res);
  void configure(Configure::Request& req, Configure::Response& res);
  // (loop) The request applied to a copy of the world: "" or why it cannot be.
  std::string configured_copy(const Configure::Request& req, corde::World* world,
                              SimSettings* settings, std::vector<std::string>* resample,
                              std::string* summary) const;
  // "" or, while the guard has given up, what a refused ~reset or ~configure adds to its reply.
  std::string stopped_note() const;
  bool on_pause(std_srvs::SetBool::Request& req, std_srvs::SetBool::Response& res);
  bool on_step(Step::Request& req, Step::Response& res);
  // (loop) Queues the steps of a ~step request; its reply is set by answer_step_call().
  void start_step_call(const Step::Request& req, Step::Response* res, const ReplyPtr& reply);
  // (loop) Answers the waiting ~step call once its steps are run, dropped, stopped by the guard,
  // or kStepCallSeconds have passed (the rest then stays queued).
  void answer_step_call(double now);
  bool on_grasp(Grasp::Request& req, Grasp::Response& res);
  bool grasp(Grasp::Request& req, Grasp::Response& res);  // on_grasp before bounding the reply
  bool on_release(Release::Request& req, Release::Response& res);
  void release(Release::Request& req, Release::Response& res);
  void pause(std_srvs::SetBool::Request& req, std_srvs::SetBool::Response& res);
  void list_grasps(ListGrasps::Response& res) const;
  bool on_list_grasps(ListGrasps::Request& req, ListGrasps::Response& res);
  // (loop) Values accepted by dynamic_reconfigure (ReconfigureInput).
  void apply_reconfigure(const NodeConfig& c);

  // Loop and outputs.
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
  // After each step (inside the guard): the contacts for rod_state and the diagnostics.
  void watch_contacts(const corde::World& world);
  void publish_due(double now);
  void publish_reactions();
  void publish_tf();
  void send_tf_to(const ros::SingleSubscriberPublisher& pub);
  void publish_markers();
  void publish_paths();  // rods/<rod>/path and rods/<rod>/poses, at the marker rate
  void publish_state();
  void publish_clock();
  void update_stats(double now);
  void diagnose(diagnostic_updater::DiagnosticStatusWrapper& stat);
  void log_status() const;
  void update_stability();
  std::string margin_text() const;
  void bump_time();
  ros::Time stamp() const;
  std::vector<GraspView> grasp_views() const;
  int benchmark_report(double wall, double cpu, unsigned long steps, double sim, double step_cpu);

  ros::NodeHandle nh_, pnh_;
  NodeParams params_;
  std::string scene_path_;
  corde::Scene initial_;  // the scene as loaded, for ~reset
  // The simulation driver: world, guard, grasps, scripts, the holder limits (configuration,
  // outside the guard's snapshot) and the commands since the snapshot (replayed after a
  // rollback); the node feeds it from the command queue and reads its state.
  corde::Simulation sim_;
  corde::World& world_ = sim_.world();
  corde::GraspSet& grasps_ = sim_.grasps();
  corde::StepGuard& guard_ = sim_.guard();
  std::map<std::string, GraspWiring> wiring_;
  bool layout_changed_ = false;  // a scripted grasp took hold or let go: refresh_layout() due
  // The one way in (command_queue.h); the loop applies it in drain_commands().
  CommandQueue commands_;
  std::atomic<bool> loop_running_{false};  // run() drains the queue: callers may wait on it
  // The ~step call waiting for its steps (loop thread only).
  struct StepCall {
    ReplyPtr reply;
    Step::Response* res = nullptr;
    long requested = 0, steps_before = 0;
    int detections_before = 0;
    double answer_by = 0.0;  // steady-clock s
  };
  std::unique_ptr<StepCall> step_call_;
  SimSettings settings_;
  int next_marker_id_ = 0;

  double time_offset_ = 0.0;  // node simulation time = time_offset_ + world_.time()
  ros::Time epoch_;           // ROS time of simulation time 0 when not publishing /clock
  Pacer pacer_;
  bool markers_clear_ = true;
  double stability_margin_ = 0.0;  // h / h_crit, largest over rods
  std::string limiting_rod_;

  // Statistics, renewed at the state rate.
  unsigned long steps_total_ = 0;
  long steps_since_stats_ = 0, substeps_per_publish_ = 0, steps_last_iteration_ = 0;
  double step_wall_since_stats_ = 0.0;
  double step_cpu_total_ = 0.0;  // thread CPU time spent in run_steps (s)
  double sim_at_stats_ = 0.0, wall_at_stats_ = 0.0;
  double step_time_us_ = 0.0, measured_rtf_ = 0.0;
  bool lagging_ = false, rtf_initialised_ = false;
  int recoveries_ = 0, recoveries_reported_ = 0;  // guard detections (all recovered or not)
  std::string last_problem_;                      // the guard's last event
  std::string guard_note_;      // restart_guard()'s note from install_scene, for ~reset's reply
  std::string strain_warning_;  // rod strained beyond its max_strain (for diagnostics)
  double last_clock_ = -1.0, last_tf_time_ = -1.0;

  // Output deadlines (steady-clock seconds).
  OutputSchedule schedule_;
  double next_status_ = 0.0;

  ros::Publisher tf_pub_, marker_pub_, state_pub_, clock_pub_;
  std::unique_ptr<ServiceThreads> services_;  // stopped in ~SimNode, after close_commands()
  std::unique_ptr<tf2_ros::Buffer> tf_buffer_;
  std::unique_ptr<TfInput> tf_input_;  // fills tf_buffer_
  std::unique_ptr<diagnostic_updater::Updater> diagnostics_;
  std::unique_ptr<ReconfigureInput> reconfigure_;  // its own thread; stopped in ~SimNode
  TfFrames tf_frames_;
  RodPaths rod_paths_;

  // Robot links as obstacles, and what was warned about them.
  RobotObstacles robot_;
  // Contacts for rod_state: the largest penetration over the steps since the last message.
  double max_penetration_since_state_ = 0.0;
  // And the deepest contact beyond deep_penetration (in radii, and its report), also for a
  // throttled warning and the diagnostics.
  double deepest_ratio_since_state_ = 0.0;
  std::string deepest_contact_since_state_;
  std::string deep_contact_warning_;
  int contact_arrows_ = 0;  // contact force arrows in the last marker array (to delete stale ones)
};

// A tf transform as an isometry (rotation normalised).
Eigen::Isometry3d to_eigen(const geometry_msgs::TransformStamped& t);

// Steady (monotonic) wall clock in seconds.
double wall_seconds();

}  // namespace corde_sim
