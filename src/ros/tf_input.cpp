// TfInput: /tf and /tf_static into the node's tf buffer.
#include "corde_sim/ros/tf_input.h"

#include <boost/function.hpp>

#include "corde_sim/ros/input_checks.h"

namespace corde_sim {

TfInput::TfInput(ros::NodeHandle& nh, tf2_ros::Buffer* buffer) : buffer_(buffer) {
  using Event = ros::MessageEvent<tf2_msgs::TFMessage const>;
  sub_ = nh.subscribe<tf2_msgs::TFMessage>(
      "/tf", 100,
      boost::function<void(const Event&)>([this](const Event& ev) { on_tf(ev, false); }));
  static_sub_ = nh.subscribe<tf2_msgs::TFMessage>(
      "/tf_static", 100,
      boost::function<void(const Event&)>([this](const Event& ev) { on_tf(ev, true); }));
}

void TfInput::on_tf(const ros::MessageEvent<tf2_msgs::TFMessage const>& ev, bool is_static) {
  if (ev.getPublisherName() == ros::this_node::getName()) return;  // our own rods
  const std::string authority = ev.getPublisherName();
  for (const geometry_msgs::TransformStamped& t : ev.getMessage()->transforms) {
    try {
      buffer_->setTransform(t, authority, is_static);
    } catch (const std::exception& e) {
      // (tf2's message quotes the frame ids, which may be of any length)
      ROS_WARN_THROTTLE(5.0, "corde_sim: ignoring a transform from %s: %s", authority.c_str(),
                        clip_reply(e.what()).c_str());
    }
  }
}

}  // namespace corde_sim
