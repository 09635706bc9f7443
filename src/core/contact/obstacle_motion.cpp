#include "corde_sim/contact/obstacle_motion.h"

namespace corde {

Eigen::Isometry3d ObstacleMotion::pose_at(double t) const {
  const Eigen::Isometry3d frame = motion ? motion->pose_at(t, start) : start;
  return frame * (local_at ? local_at(t) : local);
}

void move_obstacles(const std::vector<ObstacleMotion>& motions, double t, double h,
                    ObstacleSet* set) {
  for (const ObstacleMotion& m : motions) {
    const Eigen::Isometry3d now = m.pose_at(t), next = m.pose_at(t + h);
    const Vec3 v = (next.translation() - now.translation()) / h;
    const Eigen::AngleAxisd turn(Eigen::Matrix3d(next.linear() * now.linear().transpose()));
    const Vec3 w = (turn.angle() / h) * turn.axis();
    // Rotations drift off orthonormal by rounding over a long run: re-orthonormalise.
    Eigen::Isometry3d pose = now;
    pose.linear() = Quat(now.linear()).normalized().toRotationMatrix();
    set->set_pose(m.obstacle, pose, v, w);
  }
}

}  // namespace corde
