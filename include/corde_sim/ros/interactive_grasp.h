// An rviz interactive marker that drags a grasp of corde_sim_node: the marker starts at the
// grasp's tf frame and each drag publishes its pose to grasps/<name>/pose.
#pragma once

#include <interactive_markers/interactive_marker_server.h>
#include <ros/ros.h>
#include <visualization_msgs/InteractiveMarkerFeedback.h>

#include <memory>
#include <string>

namespace corde_sim {

class InteractiveGrasp {
 public:
  // Parameters (private): ~grasp (default hand), ~world_frame (world), ~frame_prefix (as the
  // simulator's default: the namespace + '/'), ~scale (m, 0.15), ~wait (s to wait for the grasp
  // frame, 10). Throws std::invalid_argument on a bad parameter.
  InteractiveGrasp(const ros::NodeHandle& nh, const ros::NodeHandle& pnh);

 private:
  void on_feedback(const visualization_msgs::InteractiveMarkerFeedbackConstPtr& fb);

  ros::NodeHandle nh_;
  std::string grasp_, world_frame_;
  ros::Publisher pose_pub_;
  std::unique_ptr<interactive_markers::InteractiveMarkerServer> server_;
};

}  // namespace corde_sim
