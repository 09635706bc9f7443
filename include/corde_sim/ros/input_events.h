// Inputs of the node as plain events (no ROS): callbacks check and convert a message into an
// event in the world frame and queue it; the loop applies the queue at the start of the next
// batch of steps, so nothing from a callback touches the simulation in the middle of one.
#pragma once

#include <Eigen/Geometry>
#include <string>
#include <vector>

namespace corde_sim {

struct InputEvent {
  enum class Kind { kPose, kWrench, kTwistRate };
  Kind kind = Kind::kPose;
  std::string grasp;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();  // kPose: holder pose, world frame
  double input_time = 0.0;                                 // kPose: ROS time the pose is for (s)
  Eigen::Vector3d force = Eigen::Vector3d::Zero(), torque = Eigen::Vector3d::Zero();  // world
  double rate = 0.0;  // kTwistRate (rad/s)
};

using InputQueue = std::vector<InputEvent>;

}  // namespace corde_sim
