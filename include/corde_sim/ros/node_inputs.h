// corde_sim_node's inputs: the grasps' topics (pose, wrench, twist rate), tf (goals of grasps that
// follow a frame, the robot's links) and dynamic_reconfigure. Topic callbacks run on the loop
// thread and check a message into a ROS-free input event of the command queue (command_queue.h);
// the loop turns each into a driver command (apply_input). Reconfigure updates come from their
// own thread and are applied in the loop (apply_reconfigure).
#pragma once

#include <geometry_msgs/PoseStamped.h>
#include <geometry_msgs/WrenchStamped.h>
#include <ros/ros.h>
#include <std_msgs/Float64.h>
#include <tf2_ros/buffer.h>

#include <Eigen/Geometry>
#include <memory>
#include <string>

#include "corde_sim/NodeConfig.h"
#include "corde_sim/ros/input_events.h"
#include "corde_sim/ros/reconfigure_input.h"
#include "corde_sim/ros/tf_input.h"

namespace corde_sim {

class SimNode;
struct GraspWiring;

class NodeInputs {
 public:
  explicit NodeInputs(SimNode* node) : node_(*node) {}
  // Subscribes to tf (before the first lookup).
  void start_tf();
  // dynamic_reconfigure starts from the parameters as read (its first request is queued, applied
  // by the loop); later requests come from its own thread.
  void start_reconfigure();
  // Stops dynamic_reconfigure's thread (after the command queue closed).
  void stop_reconfigure() { reconfigure_.reset(); }
  // The topics of grasp `name`: pose (topic source only), wrench, twist rate, grip, reaction,
  // slip (friction grasps).
  void wire_grasp(const std::string& name, GraspWiring* w);
  // (loop) Queues the latest pose of each tf grasp's frame, and poses the robot's links.
  void update_tf_holders();
  void update_robot();
  // (start-up) Serves tf until every robot link with collision elements has a pose, or for
  // `timeout` s: a cable resting on a robot's table must not fall through it before the table
  // is in tf. Warns, naming the links, when they do not come.
  void wait_for_robot(double timeout);
  // (loop) A grasp input, checked against its grasp (held, stamp order, tf source), becomes a
  // command of the driver at the current world time (corde::Simulation::submit).
  void apply_input(const InputEvent& e);
  // (loop) Values accepted by dynamic_reconfigure (ReconfigureInput).
  void apply_reconfigure(const NodeConfig& c);
  // `frame`'s pose in the world frame at `stamp` (0: the latest): false and why not otherwise.
  bool lookup_world(const std::string& frame, const ros::Time& stamp, Eigen::Isometry3d* out,
                    std::string* error) const;
  // An interval between input stamps (ROS time) in simulation time.
  double ros_to_sim_interval(double ros_seconds) const;
  // The node's simulation time (SimNode::sim_time()) of a ROS stamp (s): the one place that maps
  // an input's stamp to the simulation's clock.
  double sim_time_of_stamp(double ros_stamp) const;

 private:
  void on_pose(const std::string& name, const geometry_msgs::PoseStampedConstPtr& msg);
  void on_wrench(const std::string& name, const geometry_msgs::WrenchStampedConstPtr& msg);
  void on_twist_rate(const std::string& name, const std_msgs::Float64ConstPtr& msg);
  void on_grip(const std::string& name, const std_msgs::Float64ConstPtr& msg);
  bool own_frame(const std::string& frame, Eigen::Isometry3d* out) const;
  std::string check_workspace(const Eigen::Vector3d& p) const;

  SimNode& node_;
  std::unique_ptr<tf2_ros::Buffer> tf_buffer_;
  std::unique_ptr<TfInput> tf_input_;              // fills tf_buffer_
  std::unique_ptr<ReconfigureInput> reconfigure_;  // its own thread; stopped in ~SimNode
};

}  // namespace corde_sim
