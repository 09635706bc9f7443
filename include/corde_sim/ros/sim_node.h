// corde_sim_node's adapter: ROS parameters, topics, tf and services in, calls on the rod library,
// tf frames, markers, state and diagnostics out. No physics here.
//
// One thread runs the simulation loop and serves every callback between batches of steps, so
// inputs (poses, wrenches, service requests) are applied at the start of a step and nothing in
// the library is touched concurrently. The loop is paced on the steady wall clock, never on ROS
// time, so it also works when the node itself publishes /clock.
#pragma once

#include <diagnostic_updater/diagnostic_updater.h>
#include <geometry_msgs/PoseStamped.h>
#include <geometry_msgs/WrenchStamped.h>
#include <ros/ros.h>
#include <std_msgs/Float64.h>
#include <std_srvs/SetBool.h>
#include <tf2_msgs/TFMessage.h>
#include <tf2_ros/buffer.h>
#include <visualization_msgs/MarkerArray.h>

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "corde_sim/Configure.h"
#include "corde_sim/Grasp.h"
#include "corde_sim/Release.h"
#include "corde_sim/Reset.h"
#include "corde_sim/Step.h"
#include "corde_sim/WorldState.h"
#include "corde_sim/grasp.h"
#include "corde_sim/ros/configure.h"
#include "corde_sim/ros/holder_trajectory.h"
#include "corde_sim/ros/node_params.h"
#include "corde_sim/ros/outputs.h"
#include "corde_sim/ros/pacer.h"
#include "corde_sim/scene.h"

namespace corde_sim {

// A grasp and its inputs. Released grasps stay (their wrench still acts on the rod) until a reset.
struct ActiveGrasp {
  corde::GraspSpec spec;
  corde::Grasp grasp;
  GraspSource source = GraspSource::kTopic;
  std::string frame;  // followed tf frame (kTf)
  bool held = true;
  bool attached = true;  // kTf: false until the frame was first seen (the segment stays put)
  int rod_index = 0;     // into world.rods()
  int marker_id = 0;
  HolderTrajectory holder;
  double last_input_time = -1.0;  // ROS time of the last pose input (s), for its interval
  double twist_rate = 0.0;        // rad/s about the held segment's tangent
  double twist_angle = 0.0;       // rad accumulated
  corde::Vec3 force = corde::Vec3::Zero(), torque = corde::Vec3::Zero();  // world frame
  int load_index = -1;      // first of its three loads in the rod (2 forces, 1 torque)
  double arc_length = 0.0;  // material coordinate of the grasped segment's midpoint (m)
  ros::Subscriber pose_sub, wrench_sub, twist_sub;
};

class SimNode {
 public:
  // Reads and validates parameters, loads the scene and sets up ROS interfaces. Throws
  // std::invalid_argument (bad parameter) or corde::SceneError (bad scene).
  SimNode(const ros::NodeHandle& nh, const ros::NodeHandle& pnh);
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
  void remake_grasps_on(const std::string& rod);
  void hold_all(double t_end, double h);
  Eigen::Isometry3d holder_pose(const ActiveGrasp& g, double t) const;
  void update_tf_holders();
  void set_wrench_loads(ActiveGrasp* g);
  void refresh_layout();

  // Inputs.
  void on_tf(const ros::MessageEvent<tf2_msgs::TFMessage const>& ev, bool is_static);
  void on_pose(const std::string& name, const geometry_msgs::PoseStampedConstPtr& msg);
  void on_wrench(const std::string& name, const geometry_msgs::WrenchStampedConstPtr& msg);
  void on_twist_rate(const std::string& name, const std_msgs::Float64ConstPtr& msg);
  bool lookup_world(const std::string& frame, const ros::Time& stamp, Eigen::Isometry3d* out,
                    std::string* error) const;
  double ros_to_sim_interval(double ros_seconds) const;

  // Services.
  bool on_reset(Reset::Request& req, Reset::Response& res);
  bool on_configure(Configure::Request& req, Configure::Response& res);
  bool on_pause(std_srvs::SetBool::Request& req, std_srvs::SetBool::Response& res);
  bool on_step(Step::Request& req, Step::Response& res);
  bool on_grasp(Grasp::Request& req, Grasp::Response& res);
  bool on_release(Release::Request& req, Release::Response& res);

  // Loop and outputs.
  void advance(double now);
  void check_finite();
  double next_output_due() const;
  void publish_due(double now, bool force);
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
  void bump_time();
  ros::Time stamp() const;
  std::vector<GraspView> grasp_views() const;
  int benchmark_report(double wall, double cpu, unsigned long steps, double sim, double step_cpu);

  ros::NodeHandle nh_, pnh_;
  NodeParams params_;
  std::string scene_path_;
  corde::Scene initial_;  // the scene as loaded, for ~reset
  corde::World world_;
  corde::World last_good_;  // copied at every publish: restored if the state turns non-finite
  SimSettings settings_;
  std::map<std::string, ActiveGrasp> grasps_;
  int next_marker_id_ = 0;

  double time_offset_ = 0.0;  // node simulation time = time_offset_ + world_.time()
  ros::Time epoch_;           // ROS time of simulation time 0 when not publishing /clock
  bool paused_ = false;
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
  int recoveries_ = 0, recoveries_reported_ = 0;
  double last_clock_ = -1.0, last_tf_time_ = -1.0;

  // Output deadlines (steady-clock seconds).
  double next_tf_ = 0.0, next_marker_ = 0.0, next_stats_ = 0.0, next_status_ = 0.0;

  ros::Publisher tf_pub_, marker_pub_, state_pub_, clock_pub_;
  ros::Subscriber tf_sub_, tf_static_sub_;
  std::vector<ros::ServiceServer> services_;
  std::unique_ptr<tf2_ros::Buffer> tf_buffer_;
  std::unique_ptr<diagnostic_updater::Updater> diagnostics_;
  TfFrames tf_frames_;
  RodPaths rod_paths_;
};

// Steady (monotonic) wall clock in seconds.
double wall_seconds();

}  // namespace corde_sim
