// A robot's links as moving obstacles: the collision elements of its URDF, each following its
// link's pose (from tf, looked up by SimNode) through an ObstacleGlide. No ROS here: the node
// hands in poses and calls before_step() ahead of every world step.
#pragma once

#include <string>
#include <vector>

#include "corde_sim/contact/obstacle.h"
#include "corde_sim/contact/urdf_obstacles.h"
#include "corde_sim/ros/obstacle_glide.h"

namespace corde_sim {

class RobotObstacles {
 public:
  struct Link {
    std::string name;
    std::vector<int> elements;  // indices into the collision elements
    bool seen = false;          // its pose has arrived at least once
    double last_stamp = 0.0;    // ROS time of that pose (s; 0 for static frames)
  };

  // Reads every collision element of the URDF text (parse_urdf_collisions: throws
  // std::runtime_error naming `doc` and the element). Links named in `ignore` get none; a name
  // there that the robot lacks is an error too. Elements get `friction`.
  void load(const std::string& xml, const std::string& base_dir, const std::string& doc,
            double friction, const std::vector<std::string>& ignore);
  bool empty() const { return elements_.empty(); }
  // The links with collision elements whose pose has not arrived yet, comma-separated.
  std::string unseen_links() const;
  std::vector<Link>& links() { return links_; }
  const std::vector<Link>& links() const { return links_; }
  int elements() const { return static_cast<int>(elements_.size()); }
  // Elements in the obstacle set (their link has been seen).
  int active() const;

  // Adds the elements of seen links to `set` (after what it holds), at their current poses; for
  // a new world (start-up, reset).
  void install(corde::ObstacleSet* set);

  // Link k is at `pose` (world frame). The first pose adds its elements to `set` there; later
  // ones glide them over `interval` after the glide under way (s of simulation time, at most
  // `max_lag` carried over; see ObstacleGlide). Returns false if the speed caps slowed the glide
  // down.
  bool set_link_pose(corde::ObstacleSet* set, int k, const Eigen::Isometry3d& pose, double interval,
                     double max_speed, double max_angular_speed, double max_lag);

  // Before each world step of h seconds: moving elements get their pose and velocity for the
  // step. Allocates nothing.
  void before_step(corde::ObstacleSet* set, double h);

 private:
  struct Element {
    corde::UrdfCollision collision;
    ObstacleGlide glide;
    int index = -1;               // in the obstacle set, -1 while its link is unseen
    bool velocity_given = false;  // the set holds a non-zero velocity for it
  };
  std::vector<Element> elements_;
  std::vector<Link> links_;
  double friction_ = 0.5;
};

}  // namespace corde_sim
