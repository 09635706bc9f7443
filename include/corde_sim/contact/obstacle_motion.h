// Keyframed obstacles: an obstacle (or a URDF's group of links) moved along a Motion
// (motion.h), re-posed by World::step at the start of every step with the velocity that takes it
// to its pose at the step's end, so that the contact constraints see exactly where it will be.
#pragma once

#include <Eigen/Geometry>
#include <functional>
#include <memory>
#include <vector>

#include "corde_sim/contact/obstacle.h"
#include "corde_sim/rod/motion.h"

namespace corde {

struct ObstacleMotion {
  int obstacle = 0;  // index in the world's ObstacleSet
  // Moves `start` (a primitive's own frame, a URDF's root frame) about its own origin; null: the
  // frame stays at `start`.
  std::shared_ptr<const Motion> motion;
  Eigen::Isometry3d start = Eigen::Isometry3d::Identity();
  // The obstacle's frame in the moved frame: `local`, or `local_at(t)` when given (a URDF link
  // whose joints move).
  Eigen::Isometry3d local = Eigen::Isometry3d::Identity();
  std::function<Eigen::Isometry3d(double)> local_at;

  Eigen::Isometry3d pose_at(double t) const;
};

// Poses every obstacle of `motions` at time t with the velocity of the step [t, t + h]: the
// origin's displacement over h and the rotation vector of the step's rotation over h (exact for a
// translation; a rotation's chord for a turning one).
void move_obstacles(const std::vector<ObstacleMotion>& motions, double t, double h,
                    ObstacleSet* set);

}  // namespace corde
