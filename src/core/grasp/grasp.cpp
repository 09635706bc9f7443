#include "corde_sim/grasp/grasp.h"

#include <cmath>
#include <stdexcept>

namespace corde {

int grasp_segment(const Rod& rod, const GraspSpec& spec) {
  const int last = rod.num_segments() - 1;
  switch (spec.place) {
    case GraspSpec::Place::kStart:
      return 0;
    case GraspSpec::Place::kEnd:
      return last;
    case GraspSpec::Place::kNode: {
      if (!(spec.value >= 0.0) || !std::isfinite(spec.value))
        throw std::out_of_range("grasp '" + spec.name + "': node index must be >= 0");
      const double k = std::round(spec.value);
      return k >= last ? last : static_cast<int>(k);
    }
    case GraspSpec::Place::kArcLength: {
      if (!std::isfinite(spec.value))
        throw std::out_of_range("grasp '" + spec.name + "': arc length is not finite");
      const std::vector<double>& rest = rod.rest_lengths();
      double s0 = 0.0;
      int best = 0;
      double best_dist = INFINITY;
      for (int s = 0; s <= last; ++s) {
        const double dist = std::abs(s0 + 0.5 * rest[s] - spec.value);
        if (dist < best_dist) {
          best_dist = dist;
          best = s;
        }
        s0 += rest[s];
      }
      return best;
    }
  }
  return last;
}

bool grasp_holds(const GraspSpec& spec, double t, double h) {
  return t >= spec.grasp_time - 0.5 * h && t < spec.release_time - 0.5 * h;
}

std::shared_ptr<const Motion> holder_motion(const GraspSpec& spec, const Eigen::Isometry3d& start) {
  if (!spec.motion || spec.grasp_time <= 0.0) return spec.motion;
  return std::make_shared<Motion>(
      spec.motion->rebased(spec.motion_reference, start, start.linear().col(2)));
}

Eigen::Isometry3d segment_pose(const Rod& rod, int segment) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = rod.orientations()[segment].normalized().toRotationMatrix();
  pose.translation() = 0.5 * (rod.positions()[segment] + rod.positions()[segment + 1]);
  return pose;
}

void place_rod(Rod& rod, int segment, const Eigen::Isometry3d& pose) {
  const Eigen::Isometry3d move = pose * segment_pose(rod, segment).inverse();
  const Quat turn(move.linear());
  for (Vec3& x : rod.positions()) x = move * x;
  for (Vec3& v : rod.velocities()) v = move.linear() * v;
  for (Quat& q : rod.orientations()) q = (turn * q).normalized();
}

Grasp make_grasp(const Rod& rod, const GraspSpec& spec, const Eigen::Isometry3d& holder_pose) {
  Grasp g;
  g.name = spec.name;
  g.rod = rod.name();
  g.segment = grasp_segment(rod, spec);
  g.offset = holder_pose.inverse() * segment_pose(rod, g.segment);
  g.hold_orientation = spec.hold_orientation;
  return g;
}

void hold(Rod& rod, const Grasp& grasp, const Eigen::Isometry3d& holder_pose) {
  const Eigen::Isometry3d pose = holder_pose * grasp.offset;
  const Quat q(pose.linear());
  const double length = grasp.length > 0.0 ? grasp.length : rod.rest_lengths()[grasp.segment];
  const Vec3 half = (0.5 * length) * pose.linear().col(2);
  const Vec3 targets[2] = {pose.translation() - half, pose.translation() + half};
  for (int k = 0; k < 2; ++k) {
    const int node = grasp.segment + k;
    NodeDrive* d = rod.node_drive(node);
    if (d) {
      d->kind = NodeDrive::Kind::kTarget;
      d->target = targets[k];
    } else {
      NodeDrive nd;
      nd.kind = NodeDrive::Kind::kTarget;
      nd.node = node;
      nd.origin = rod.positions()[node];
      nd.target = targets[k];
      rod.add_node_drive(nd);
    }
  }
  if (!grasp.hold_orientation) return;
  SegmentDrive* d = rod.segment_drive(grasp.segment);
  if (d) {
    d->kind = SegmentDrive::Kind::kTarget;
    d->target = q;
  } else {
    SegmentDrive sd;
    sd.kind = SegmentDrive::Kind::kTarget;
    sd.segment = grasp.segment;
    sd.origin = rod.orientations()[grasp.segment];
    sd.target = q;
    rod.add_segment_drive(sd);
  }
}

void release(Rod& rod, const Grasp& grasp) {
  for (int k = 0; k < 2; ++k) {
    const NodeDrive* d = rod.node_drive(grasp.segment + k);
    if (d && d->kind == NodeDrive::Kind::kTarget) rod.remove_node_drive(grasp.segment + k);
  }
  const SegmentDrive* d = rod.segment_drive(grasp.segment);
  if (d && d->kind == SegmentDrive::Kind::kTarget) rod.remove_segment_drive(grasp.segment);
}

}  // namespace corde
