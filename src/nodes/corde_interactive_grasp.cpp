// corde_interactive_grasp: drag a grasp of corde_sim_node with an rviz interactive marker.
#include <ros/ros.h>

#include "corde_sim/ros/interactive_grasp.h"

int main(int argc, char** argv) {
  ros::init(argc, argv, "corde_interactive_grasp");
  // Handles outlive the node object: destroying the last one shuts ROS (and its logging) down,
  // which would swallow the fatal message below.
  ros::NodeHandle nh, pnh("~");
  try {
    corde_sim::InteractiveGrasp node(nh, pnh);
    ros::spin();
  } catch (const std::exception& e) {
    ROS_FATAL("corde_interactive_grasp: cannot start: %s", e.what());
    return 1;
  }
  return 0;
}
