#include "corde_sim/ros/interactive_grasp.h"

#include <geometry_msgs/PoseStamped.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>
#include <visualization_msgs/InteractiveMarker.h>

#include <cmath>
#include <stdexcept>

namespace corde_sim {
namespace {

visualization_msgs::InteractiveMarkerControl axis_control(const std::string& name, double x,
                                                          double y, double z, bool rotate) {
  visualization_msgs::InteractiveMarkerControl c;
  c.name = name;
  c.orientation.w = 1.0;
  c.orientation.x = x;
  c.orientation.y = y;
  c.orientation.z = z;
  c.interaction_mode = rotate ? visualization_msgs::InteractiveMarkerControl::ROTATE_AXIS
                              : visualization_msgs::InteractiveMarkerControl::MOVE_AXIS;
  return c;
}

}  // namespace

InteractiveGrasp::InteractiveGrasp(const ros::NodeHandle& nh, const ros::NodeHandle& pnh)
    : nh_(nh) {
  pnh.param<std::string>("grasp", grasp_, "hand");
  pnh.param<std::string>("world_frame", world_frame_, "world");
  std::string prefix = nh.getNamespace();
  while (!prefix.empty() && prefix.front() == '/') prefix.erase(0, 1);
  if (!prefix.empty()) prefix += '/';
  pnh.param<std::string>("frame_prefix", prefix, prefix);
  if (!prefix.empty() && prefix.back() != '/') prefix += '/';
  double scale = 0.15, wait = 10.0;
  pnh.param("scale", scale, 0.15);
  pnh.param("wait", wait, 10.0);
  if (grasp_.empty()) throw std::invalid_argument("parameter ~grasp: must not be empty");
  if (world_frame_.empty() || world_frame_[0] == '/')
    throw std::invalid_argument("parameter ~world_frame: non-empty, no leading slash");
  if (!(scale > 0.0)) throw std::invalid_argument("parameter ~scale: must be > 0");

  // Start where the grasp is, so that the first drag does not jerk the rod.
  geometry_msgs::Pose start;
  start.orientation.w = 1.0;
  {
    tf2_ros::Buffer buffer;
    tf2_ros::TransformListener listener(buffer);
    const std::string frame = prefix + "grasp/" + grasp_;
    try {
      const auto t = buffer.lookupTransform(world_frame_, frame, ros::Time(0), ros::Duration(wait));
      start.position.x = t.transform.translation.x;
      start.position.y = t.transform.translation.y;
      start.position.z = t.transform.translation.z;
      start.orientation = t.transform.rotation;
    } catch (const tf2::TransformException& e) {
      ROS_WARN("corde_interactive_grasp: frame %s not found (%s); the marker starts at the origin",
               frame.c_str(), e.what());
    }
  }

  pose_pub_ = nh_.advertise<geometry_msgs::PoseStamped>("grasps/" + grasp_ + "/pose", 10);
  server_ = std::make_unique<interactive_markers::InteractiveMarkerServer>(
      "corde_interactive_grasp", "", false);

  visualization_msgs::InteractiveMarker m;
  m.header.frame_id = world_frame_;
  m.name = grasp_;
  m.description = "grasp " + grasp_;
  m.scale = scale;
  m.pose = start;
  visualization_msgs::InteractiveMarkerControl free;
  free.name = "move_3d";
  free.orientation.w = 1.0;
  free.interaction_mode = visualization_msgs::InteractiveMarkerControl::MOVE_ROTATE_3D;
  free.always_visible = true;
  visualization_msgs::Marker ball;
  ball.type = visualization_msgs::Marker::SPHERE;
  ball.scale.x = ball.scale.y = ball.scale.z = 0.3 * scale;
  ball.color.r = 1.0;
  ball.color.g = 0.6;
  ball.color.a = 0.9;
  free.markers.push_back(ball);
  m.controls.push_back(free);
  const double s = std::sqrt(0.5);
  m.controls.push_back(axis_control("move_x", s, 0, 0, false));
  m.controls.back().orientation.w = s;
  m.controls.push_back(axis_control("rotate_x", s, 0, 0, true));
  m.controls.back().orientation.w = s;
  m.controls.push_back(axis_control("move_z", 0, s, 0, false));
  m.controls.back().orientation.w = s;
  m.controls.push_back(axis_control("rotate_z", 0, s, 0, true));
  m.controls.back().orientation.w = s;
  m.controls.push_back(axis_control("move_y", 0, 0, s, false));
  m.controls.back().orientation.w = s;
  m.controls.push_back(axis_control("rotate_y", 0, 0, s, true));
  m.controls.back().orientation.w = s;
  server_->insert(m, [this](const visualization_msgs::InteractiveMarkerFeedbackConstPtr& fb) {
    on_feedback(fb);
  });
  server_->applyChanges();
  ROS_INFO("corde_interactive_grasp: drag the marker to move grasp '%s' (publishing %s)",
           grasp_.c_str(), pose_pub_.getTopic().c_str());
}

void InteractiveGrasp::on_feedback(
    const visualization_msgs::InteractiveMarkerFeedbackConstPtr& fb) {
  if (fb->event_type != visualization_msgs::InteractiveMarkerFeedback::POSE_UPDATE &&
      fb->event_type != visualization_msgs::InteractiveMarkerFeedback::MOUSE_UP)
    return;
  geometry_msgs::PoseStamped p;
  p.header.frame_id = fb->header.frame_id.empty() ? world_frame_ : fb->header.frame_id;
  p.header.stamp = ros::Time::now();
  p.pose = fb->pose;
  pose_pub_.publish(p);
}

}  // namespace corde_sim
