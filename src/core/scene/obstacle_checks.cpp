#include "corde_sim/scene/obstacle_checks.h"

#include <algorithm>
#include <cmath>

#include "corde_sim/contact/obstacle_checks.h"
#include "corde_sim/scene/scene_bounds.h"
#include "scene_reader.h"

namespace corde {
namespace {

using scene_detail::num;

// "" or why `v` (named `what`) is not in (0, hi] metres.
std::string length_error(const std::string& what, double v, double hi) {
  if (!std::isfinite(v)) return what + " must be a finite number, got " + num(v);
  if (!(v > 0.0)) return what + " must be > 0 m, got " + num(v);
  if (v > hi) return what + " must be <= " + num(hi) + " m, got " + num(v);
  return "";
}

}  // namespace

std::string obstacle_value_error(const Obstacle& o) {
  using B = SceneBounds;
  using K = ObstacleShape::Kind;
  if (!std::isfinite(o.friction) || o.friction < 0.0 || o.friction > B::max_factor)
    return "friction must be in [0, " + num(B::max_factor) + "], got " + num(o.friction);
  if (!o.pose.matrix().allFinite()) return "the pose is not finite";
  const Eigen::Matrix3d r = o.pose.linear();
  if (!(r.transpose() * r).isApprox(Eigen::Matrix3d::Identity(), 1e-6) || !(r.determinant() > 0))
    return "the pose's orientation is not a rotation";
  const Vec3& s = o.shape.size;
  std::string why;
  switch (o.shape.kind) {
    case K::kBox:
      for (int i = 0; i < 3 && why.empty(); ++i)
        why = length_error("box side " + std::to_string(i), s[i], B::max_length);
      return why;
    case K::kSphere:
      return length_error("radius", s.x(), B::max_length);
    case K::kCylinder:
    case K::kCapsule:
      why = length_error("radius", s.x(), B::max_length);
      return why.empty() ? length_error("length", s.y(), B::max_length) : why;
    case K::kPlane:
    case K::kMesh:
      return "";
  }
  return "";
}

std::string obstacle_placement_error(const Obstacle& o) {
  return check_placed_extent(o, SceneBounds::max_placed_length);
}

}  // namespace corde
