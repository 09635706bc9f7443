// Parameters of corde_sim_node: read from the private namespace, validated and logged.
#pragma once

#include <ros/node_handle.h>

#include <Eigen/Geometry>
#include <map>
#include <string>
#include <vector>

namespace corde_sim {

enum class MarkerStyle { kLineStrip, kCylinders };

// How a grasp's holder moves: from grasps/<name>/pose messages, by following a tf frame, or not
// at all (it holds the pose it had when it was made).
enum class GraspSource { kTopic, kTf, kFixed };

// What happens when the rod strains beyond its material's max_strain.
enum class StrainAction { kWarn, kSlip };

struct GraspSourceParam {
  GraspSource source = GraspSource::kTopic;
  std::string frame;  // tf frame followed when source is kTf
  // The held segment's pose in the holder frame. Not given: topic and fixed grasps hold the
  // segment frame itself (offset identity), tf grasps keep the offset the segment has when the
  // frame first appears.
  bool has_offset = false;
  Eigen::Isometry3d offset = Eigen::Isometry3d::Identity();
  // tf grasps: true = glide to the offset (given, or identity) when the frame appears, instead of
  // keeping the one the segment has then.
  bool snap = false;
  // Scene grasps: at start-up (and ~reset) the rod is moved rigidly so that the held segment sits
  // at `frame` (times the offset, when given), waiting up to start_timeout s of wall time for the
  // frame, then settled in static equilibrium hanging from it.
  bool start_at_frame = false;
  double start_timeout = 10.0;
};

struct NodeParams {
  std::string scene;                   // YAML scene file
  std::vector<std::string> overrides;  // "key.path=value" applied to the scene (load_scene)
  std::string integrator;              // "" = the scene's; else a name or auto (added to overrides)
  std::string world_frame = "world";
  std::string frame_prefix;       // "" or ends with '/'
  double real_time_factor = 1.0;  // 0 = as fast as possible
  bool publish_clock = false;
  double tf_rate = 50.0;  // Hz of wall time, 0 = off
  int tf_every_k = 1;
  bool node_frames = false;   // also a frame at every node (<rod>/node_<i>)
  double marker_rate = 20.0;  // Hz of wall time, 0 = off
  double state_rate = 50.0;   // Hz of wall time, 0 = off
  // surface_cloud (sensor_msgs/PointCloud2): Hz of wall time (0 = off; built only while someone
  // subscribes), and its density (surface_cloud.h).
  double cloud_rate = 10.0;
  int cloud_points_per_ring = 8, cloud_rings_per_segment = 1;
  MarkerStyle marker_style = MarkerStyle::kCylinders;
  bool show_frames = false;
  bool color_by_strain = true;
  double marker_min_diameter = 0.004;  // m: thin rods are drawn at least this thick
  double max_pose_age = 1.0;           // s
  double max_frame_age = 1.0;          // s: a tf frame not updated for longer is not used
  double max_grasp_distance = 0.05;    // m: ~grasp by point refuses points farther from the rod
  // Grasp holders: limits of the motion towards their commanded poses.
  double holder_max_speed = 2.0, holder_max_acceleration = 50.0;                     // m/s, m/s^2
  double holder_max_angular_speed = 20.0, holder_max_angular_acceleration = 1000.0;  // rad/s(^2)
  // Poses outside this box (world frame, m) are refused.
  Eigen::Vector3d workspace_min = Eigen::Vector3d::Constant(-10.0);
  Eigen::Vector3d workspace_max = Eigen::Vector3d::Constant(10.0);
  StrainAction strain_action = StrainAction::kWarn;
  // A state with a node faster or a segment spinning faster than this has blown up.
  double max_node_speed = 100.0, max_angular_speed = 1e5;  // m/s, rad/s
  double loop_rate = 200.0;                                // Hz: wake-ups of the paced loop
  bool start_paused = false;
  double status_period = 10.0;  // s of wall time between status lines in the log; 0 = none
  double benchmark = 0.0;       // s of wall time; > 0 runs, prints timings and exits
  std::map<std::string, GraspSourceParam> grasps;  // ~grasps/<name>/{source,frame,...}
  // A robot's links as moving obstacles (docs/ros_interface.md, "Robot collision").
  bool robot_collision = false;                         // true, or robot_urdf_file given: on
  std::string robot_description = "robot_description";  // the parameter holding the URDF
  std::string robot_urdf_file;                          // a URDF file instead of the parameter
  double robot_friction = 0.5;
  std::vector<std::string> robot_ignore_links;
  std::string robot_frame_prefix;                                // tf frame of link L: prefix + L
  double robot_max_speed = 5.0, robot_max_angular_speed = 30.0;  // m/s, rad/s
  double robot_start_timeout = 10.0;  // s (wall): start-up waits this long for the links in tf
  // Contacts in rviz: points and forces (N drawn as contact_force_scale m per N).
  bool contact_markers = false;
  double contact_force_scale = 0.05;  // m/N
};

// "" when `value` lies in the range of parameter ~`name` in the key-range table
// (scene/key_ranges.h, shared with ~configure and cfg/Node.cfg); otherwise "parameter ~<name>: "
// and range_violation()'s reason, as ~configure words it. Throws std::logic_error for a name the
// table lacks.
std::string start_up_range_error(const std::string& name, double value);

// Parses "topic" | "tf" | "fixed"; throws std::invalid_argument otherwise.
GraspSource parse_grasp_source(const std::string& s);
const char* to_string(GraspSource s);

// Reads every parameter from `pnh` (the private handle), validates it and logs it. `ns` is the
// node's namespace, used for the default frame prefix. Throws std::invalid_argument with a
// message naming the parameter on a bad value.
NodeParams load_node_params(const ros::NodeHandle& pnh, const std::string& ns,
                            const std::string& default_scene);

}  // namespace corde_sim
