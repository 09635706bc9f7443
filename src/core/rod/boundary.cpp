#include "corde_sim/rod/boundary.h"

#include <algorithm>

namespace corde {

Vec3 drive_position(const NodeDrive& d, double t, Vec3* velocity) {
  Vec3 v = Vec3::Zero(), x = d.origin;
  switch (d.kind) {
    case NodeDrive::Kind::kVelocity:
      x = d.origin + std::max(0.0, t - d.t_start) * d.velocity;
      if (t > d.t_start) v = d.velocity;
      break;
    case NodeDrive::Kind::kTarget:
      x = d.target;
      break;
    case NodeDrive::Kind::kMotion:
      if (d.motion) {
        const Motion::Sample s = d.motion->at(t);
        const Vec3 arm = s.rotation * (d.origin - d.pivot);
        x = d.pivot + s.displacement + arm;
        v = s.velocity + s.angular_velocity.cross(arm);
      }
      break;
    case NodeDrive::Kind::kFixed:
      break;
  }
  if (velocity) *velocity = v;
  return x;
}

Quat drive_orientation(const SegmentDrive& d, double t, Vec3* angular_velocity) {
  Vec3 w = Vec3::Zero();
  Quat q = d.origin;
  switch (d.kind) {
    case SegmentDrive::Kind::kSpin:
      q = d.origin * Quat(Eigen::AngleAxisd(d.rate * std::max(0.0, t - d.t_start), Vec3::UnitZ()));
      if (t > d.t_start) w = q * Vec3(0.0, 0.0, d.rate);
      break;
    case SegmentDrive::Kind::kTarget:
      q = d.target.normalized();
      break;
    case SegmentDrive::Kind::kMotion:
      if (d.motion) {
        const Motion::Sample s = d.motion->at(t);
        q = (s.rotation * d.origin).normalized();
        w = s.angular_velocity;
      }
      break;
    case SegmentDrive::Kind::kFixed:
      break;
  }
  if (angular_velocity) *angular_velocity = w;
  return q;
}

Quat drive_orientation_near(const SegmentDrive& d, double t, const Quat& near,
                            Vec3* angular_velocity) {
  Quat q = drive_orientation(d, t, angular_velocity);
  if (q.coeffs().dot(near.coeffs()) < 0.0) q.coeffs() *= -1.0;
  return q;
}

DrivenNode drive_state(const NodeDrive& d, double t_end, double h, const Vec3& x) {
  DrivenNode s;
  if (d.kind == NodeDrive::Kind::kTarget) {
    s.velocity = (d.target - x) / h;
    s.position = d.target;
  } else {
    s.position = drive_position(d, t_end, &s.velocity);
  }
  return s;
}

DrivenSegment drive_state(const SegmentDrive& d, double t_end, double h, const Quat& q) {
  DrivenSegment s;
  if (d.kind == SegmentDrive::Kind::kTarget) {
    s.orientation = drive_orientation_near(d, t_end, q);
    // The turn from q to the target, about an axis that is the same in both body frames.
    const Eigen::AngleAxisd delta(q.conjugate() * s.orientation);
    s.angular_velocity = (delta.angle() / h) * delta.axis();
    s.world_angular_velocity = q * s.angular_velocity;
  } else {
    s.orientation = drive_orientation(d, t_end, &s.world_angular_velocity);
    s.angular_velocity = s.orientation.conjugate() * s.world_angular_velocity;
  }
  return s;
}

Quat ghost_frame_at(const GhostFrame& g, double t) {
  if (!g.motion) return g.frame;
  return (g.motion->at(t).rotation * g.origin).normalized();
}

}  // namespace corde
