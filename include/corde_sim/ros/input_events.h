// Inputs of the node as plain events (no ROS): callbacks check and convert a message into an
// event in the world frame and queue it (command_queue.h); the loop applies it before its next
// batch of steps, so nothing from a callback touches the simulation in the middle of one.
#pragma once

#include <Eigen/Geometry>
#include <string>

namespace corde_sim {

struct InputEvent {
  // kFrame: a new pose of the tf frame a grasp follows (input_time: its stamp).
  // kGrip: a friction grasp's grip force (grip_force).
  enum class Kind { kPose, kWrench, kTwistRate, kFrame, kGrip };
  Kind kind = Kind::kPose;
  std::string grasp;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();  // kPose, kFrame: world frame
  double input_time = 0.0;  // kPose, kFrame: ROS time the pose is for (s)
  bool stamped = false;     // kPose: input_time is the message's stamp (not its arrival)
  Eigen::Vector3d force = Eigen::Vector3d::Zero(), torque = Eigen::Vector3d::Zero();  // world
  double rate = 0.0;        // kTwistRate (rad/s)
  double grip_force = 0.0;  // kGrip (N)
};

}  // namespace corde_sim
