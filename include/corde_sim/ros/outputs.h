// Turns library state into ROS messages: tf frames, rviz markers and the rod_state message.
// Buffers are kept between calls so that a 1000-segment rod costs no per-publish allocation of
// frame names.
#pragma once

#include <geometry_msgs/PoseArray.h>
#include <geometry_msgs/TransformStamped.h>
#include <nav_msgs/Path.h>
#include <ros/node_handle.h>
#include <ros/publisher.h>
#include <ros/time.h>
#include <std_msgs/Header.h>
#include <visualization_msgs/MarkerArray.h>

#include <Eigen/Geometry>
#include <map>
#include <string>
#include <vector>

#include "corde_sim/WorldState.h"
#include "corde_sim/ros/node_params.h"
#include "corde_sim/world/world.h"

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
  // k-th segment (midpoint, segment orientation), <prefix><rod>/tip (last node, last segment's
  // orientation), with node frames also <prefix><rod>/node_<i> for every node (orientation of
  // segment i, the last node of the last segment), <prefix>grasp/<name>; all children of world.
  // set_node_frames takes effect at the next layout.
  void set_node_frames(bool on) { node_frames_ = on; }
  void layout(const corde::World& world, const std::vector<GraspView>& grasps,
              const std::string& prefix, const std::string& world_frame, int every_k);
  const std::vector<geometry_msgs::TransformStamped>& update(const corde::World& world,
                                                             const std::vector<GraspView>& grasps,
                                                             const ros::Time& stamp);
  size_t size() const { return tfs_.size(); }

 private:
  int every_k_ = 1;
  bool node_frames_ = false;
  bool laid_out_node_frames_ = false;  // what tfs_ was laid out with (update follows it)
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
// <rod>/frames (director triads), clamps (a grey box at each fixed node and ghost-clamped end, id =
// the node's index counted over all rods), legend (with colour by strain: the strain scale of each
// rod as text, id = rod index), grasps and grasp_labels (id per grasp). clear_first prepends a
// DELETEALL so that markers of removed segments or grasps disappear after a layout change.
void build_markers(const corde::World& world, const std::vector<GraspView>& grasps,
                   const MarkerOptions& options, const ros::Time& stamp, bool clear_first,
                   visualization_msgs::MarkerArray* out);

// Contacts of the world's last step (time step h), appended to `out`: namespace `contacts`, id
// 0, a SPHERE_LIST of the contact points on the obstacle's (or other rod's) surface, red for the
// contacts that carried a force and grey for those only within the detection margin (deleted
// when there are none); namespace `contact_forces`, an ARROW per contact that carried a force
// (ids 0..n-1 in the contact list's order), from the point along the force on the rod,
// force_scale metres per newton (at most 0.5 m long). Arrows with ids n..previous-1 (the count
// returned for the last array) are deleted. Returns n.
int add_contact_markers(const corde::World& world, double force_scale, const MarkerOptions& o,
                        const ros::Time& stamp, int previous, visualization_msgs::MarkerArray* out);

// Surface strain r |u - uhat| of bending and twist per segment (mean of its orientation
// elements), for colouring.
void segment_strains(const corde::Rod& rod, std::vector<double>* strain);

// Text of a rod's strain legend: "<rod>: blue 0 .. red <top> surface strain".
std::string strain_legend(const std::string& rod, double top);

// The centreline as a path: N + 1 poses at the nodes, node i with segment i's orientation and
// the last node with the last segment's. The header (also each pose's) is the caller's.
void fill_path(const corde::Rod& rod, const std_msgs::Header& header, nav_msgs::Path* out);
// The N segment frames: midpoints with the segments' orientations.
void fill_segment_poses(const corde::Rod& rod, const std_msgs::Header& header,
                        geometry_msgs::PoseArray* out);

// Per rod a nav_msgs/Path on rods/<rod>/path and a geometry_msgs/PoseArray on rods/<rod>/poses,
// relative to the handle's namespace. Topics follow the rods of the world (advertised when a rod
// first appears, dropped with it); a message is built only for a topic with subscribers.
class RodPaths {
 public:
  void publish(ros::NodeHandle& nh, const corde::World& world, const std::string& world_frame,
               const ros::Time& stamp);

 private:
  struct Topics {
    bool valid = false;  // false: the rod's name makes no valid topic name (warned once)
    ros::Publisher path, poses;
  };
  std::map<std::string, Topics> topics_;
};

// Rods of the world into msg->rods (positions, orientations, velocities, world angular
// velocities, energies); the header and statistics are the caller's.
void fill_rod_states(const corde::World& world, WorldState* msg);

}  // namespace corde_sim
