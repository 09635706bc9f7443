// Obstacles added, moved and removed while the node runs (~add_obstacle, ~remove_obstacle): a
// request's shape (shape_msgs' fields, copied into ObstacleRequest) checked and turned into an
// obstacle, and the obstacles kept in the world's set at stable indices, each posed in a frame
// that may move (a tf frame, followed through an ObstacleGlide like a robot link). No ROS here:
// the node resolves frames and calls these on the loop thread.
#pragma once

#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "corde_sim/contact/obstacle.h"
#include "corde_sim/ros/obstacle_glide.h"

namespace corde_sim {

// shape_msgs/SolidPrimitive's type numbers; the dimensions' order is its too.
enum PrimitiveType : int { kNoPrimitive = 0, kBox = 1, kSphere = 2, kCylinder = 3, kCone = 4 };

// Limits on a run-time obstacle (docs/ros_interface.md, "Run-time obstacles").
constexpr double kMaxObstacleLength = 1.0e4;    // m: a size, a vertex coordinate
constexpr double kMaxObstacleExtent = 1.0e5;    // m: position or size as placed in the world
constexpr double kMaxObstacleFriction = 1.0e6;  // like a scene's friction
constexpr size_t kMaxMeshTriangles = 1000000;
constexpr size_t kMaxMeshVertices = 3000000;
constexpr int kMaxRuntimeObstacles = 1000;

struct ObstacleRequest {
  std::string name;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();  // checked, not assumed unit
  int primitive_type = kNoPrimitive;
  std::vector<double> dimensions;
  std::vector<Eigen::Vector3d> vertices;
  std::vector<std::array<uint32_t, 3>> triangles;
  Eigen::Vector4d plane = Eigen::Vector4d::Zero();  // a x + b y + c z + d = 0; all 0 = none
  double friction = 0.5;
};

// The obstacle a request describes, with its pose in the request's frame (a plane's frame: on the
// plane, z its normal towards the free side). Throws std::invalid_argument naming the field and
// value: an empty or overlong name, a non-finite or non-unit pose, no shape or more than one, an
// unsupported primitive (cone), dimensions missing, non-positive or beyond kMaxObstacleLength, a
// mesh too large, with non-finite or far vertices or indices out of range, a plane without a
// normal, a bad friction.
corde::Obstacle obstacle_from_request(const ObstacleRequest& r);

// "box", "sphere", "cylinder", "capsule", "plane", "mesh".
const char* shape_kind_name(corde::ObstacleShape::Kind kind);

class RuntimeObstacles {
 public:
  struct Entry {
    std::string frame;                                             // "" = the world frame (fixed)
    corde::Obstacle obstacle;                                      // pose: in `frame`
    Eigen::Isometry3d frame_pose = Eigen::Isometry3d::Identity();  // frame in the world, last seen
    ObstacleGlide glide;
    int index = -1;  // in the world's obstacle set
    bool velocity_given = false;
    bool in_tf = true;        // the frame was found at the last look
    double last_stamp = 0.0;  // stamp of frame_pose (ROS time, s; 0: static)
  };

  // Adds the obstacle `o` (pose in `frame`, "" = the world frame, at `frame_pose` in the world) to
  // `set`, or with `replace` puts it in place of the one of the same name (at once: no glide).
  // Throws std::invalid_argument, `set` unchanged: a name taken by another obstacle of the set
  // (the scene's, the robot's) or, without `replace`, by a run-time one; too many; placed beyond
  // kMaxObstacleExtent; what ObstacleSet::add refuses. Returns whether it replaced one.
  bool add(corde::ObstacleSet* set, corde::Obstacle o, const std::string& frame,
           const Eigen::Isometry3d& frame_pose, double stamp, bool replace);
  // Removes obstacle `name` (its slot stays, disabled, for the next add). Throws
  // std::invalid_argument for a name that is no run-time obstacle.
  void remove(corde::ObstacleSet* set, const std::string& name);
  // A new world (start-up, reset): every obstacle joins `set` (after what it holds) at its pose.
  void install(corde::ObstacleSet* set);

  std::vector<Entry>& entries() { return entries_; }
  const std::vector<Entry>& entries() const { return entries_; }
  // The world pose obstacle k has now.
  Eigen::Isometry3d world_pose(int k) const { return entries_[k].glide.pose(); }

  // Entry k's frame is at `frame_pose` (world): glides there over `interval` (s of simulation
  // time; see ObstacleGlide). Returns false if the speed caps slowed the glide down.
  bool set_frame_pose(int k, const Eigen::Isometry3d& frame_pose, double interval, double max_speed,
                      double max_angular_speed, double max_lag);
  // Before each world step of h seconds: gliding obstacles get their pose and velocity for the
  // step. Allocates nothing.
  void before_step(corde::ObstacleSet* set, double h);

 private:
  int find(const std::string& name) const;
  std::vector<Entry> entries_;
  std::vector<int> free_;  // disabled slots of the set, for reuse
};

}  // namespace corde_sim
