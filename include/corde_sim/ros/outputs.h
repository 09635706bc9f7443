// Turns library state into ROS messages: tf frames, rviz markers and the rod_state message.
// Buffers are kept between calls so that a 1000-segment rod costs no per-publish allocation of
// frame names.
#pragma once

#include <geometry_msgs/TransformStamped.h>
#include <ros/time.h>
#include <visualization_msgs/MarkerArray.h>

#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "corde_sim/WorldState.h"
#include "corde_sim/ros/node_params.h"
#include "corde_sim/world.h"

namespace corde_sim {

// A grasp as drawn: its frame name and the holder's pose in the world frame.
struct GraspView {
  std::string name;
  int id = 0;  // stable marker id
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
};

class TfFrames {
 public:
  // Frame names: <prefix><rod> (node 0, orientation of segment 0), <prefix><rod>/seg_<k> for every
  // k-th segment (midpoint, segment orientation), <prefix>grasp/<name>; all children of world.
  void layout(const corde::World& world, const std::vector<GraspView>& grasps,
              const std::string& prefix, const std::string& world_frame, int every_k);
  const std::vector<geometry_msgs::TransformStamped>& update(const corde::World& world,
                                                             const std::vector<GraspView>& grasps,
                                                             const ros::Time& stamp);
  size_t size() const { return tfs_.size(); }

 private:
  int every_k_ = 1;
  std::vector<geometry_msgs::TransformStamped> tfs_;
};

struct MarkerOptions {
  MarkerStyle style = MarkerStyle::kCylinders;
  bool show_frames = false;
  bool color_by_strain = true;
  double min_diameter = 0.004;
  int frames_every_k = 1;
  std::string world_frame = "world";
};

// One MarkerArray for all rods: namespace <rod> (ids 0..N-1 for cylinders, 0 for a line strip),
// <rod>/frames (director triads), grasps and grasp_labels (id per grasp). clear_first prepends a
// DELETEALL so that markers of removed segments or grasps disappear after a layout change.
void build_markers(const corde::World& world, const std::vector<GraspView>& grasps,
                   const MarkerOptions& options, const ros::Time& stamp, bool clear_first,
                   visualization_msgs::MarkerArray* out);

// Surface strain r |u - uhat| of bending and twist per segment (mean of its orientation
// elements), for colouring.
void segment_strains(const corde::Rod& rod, std::vector<double>* strain);

// Rods of the world into msg->rods (positions, orientations, velocities, world angular
// velocities, energies); the header and statistics are the caller's.
void fill_rod_states(const corde::World& world, WorldState* msg);

}  // namespace corde_sim
