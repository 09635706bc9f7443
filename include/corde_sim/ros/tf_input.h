// tf as an input of corde_sim_node: its own subscriptions to /tf and /tf_static fill a tf buffer,
// skipping the node's own (large) /tf messages without storing them. Callbacks run on the loop's
// callback queue; the buffer is read by the loop (frames followed by grasps, robot links).
#pragma once

#include <ros/ros.h>
#include <tf2_msgs/TFMessage.h>
#include <tf2_ros/buffer.h>

namespace corde_sim {

class TfInput {
 public:
  // `buffer` must outlive this object.
  TfInput(ros::NodeHandle& nh, tf2_ros::Buffer* buffer);

 private:
  void on_tf(const ros::MessageEvent<tf2_msgs::TFMessage const>& ev, bool is_static);

  tf2_ros::Buffer* buffer_;
  ros::Subscriber sub_, static_sub_;
};

}  // namespace corde_sim
