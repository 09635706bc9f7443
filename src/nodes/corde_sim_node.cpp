// corde_sim_node: simulates the rods of a scene and serves them over ROS (see
// docs/ros_interface.md).
#include <ros/ros.h>

#include "corde_sim/ros/sim_node.h"

int main(int argc, char** argv) {
  ros::init(argc, argv, "corde_sim_node");
  // Handles outlive the node object: destroying the last one shuts ROS (and its logging) down,
  // which would swallow the fatal message below.
  ros::NodeHandle nh, pnh("~");
  try {
    corde_sim::SimNode node(nh, pnh);
    return node.run();
  } catch (const std::exception& e) {
    ROS_FATAL("corde_sim: cannot start: %s", e.what());
    return 1;
  }
}
