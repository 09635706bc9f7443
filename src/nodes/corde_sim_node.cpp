// corde_sim_node: simulates the rods of a scene and serves them over ROS (see
// docs/ros_interface.md).
#include <ros/ros.h>

#include "corde_sim/ros/sim_node.h"

int main(int argc, char** argv) {
  ros::init(argc, argv, "corde_sim_node");
  try {
    corde_sim::SimNode node(ros::NodeHandle(), ros::NodeHandle("~"));
    return node.run();
  } catch (const std::exception& e) {
    ROS_FATAL("corde_sim: cannot start: %s", e.what());
    return 1;
  }
}
