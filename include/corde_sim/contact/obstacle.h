// Obstacles a rod can touch: primitives (plane, box, sphere, cylinder, capsule) and triangle
// meshes, posed in the world, and the closest-point query between one rod segment's axis and an
// obstacle. Boxes, cylinders and meshes are queried through FCL (with the signed distance of a
// penetrating axis computed here for boxes and cylinders); the plane (a half-space), spheres and
// capsules analytically.
#pragma once

#include <Eigen/Geometry>
#include <memory>
#include <string>
#include <vector>

#include "corde_sim/model/element_energies.h"

namespace corde {

// Triangles in the obstacle's own frame (already scaled).
struct TriangleMesh {
  std::vector<Vec3> vertices;
  std::vector<Eigen::Vector3i> triangles;
};

struct ObstacleShape {
  enum class Kind { kPlane, kBox, kSphere, kCylinder, kCapsule, kMesh };
  Kind kind = Kind::kBox;
  // kBox: full side lengths (x, y, z); kSphere: radius in x; kCylinder and kCapsule: radius in x,
  // length of the axis (z of the obstacle frame) in y; kPlane: none (the half-space z <= 0 of the
  // obstacle frame, its surface the plane z = 0); kMesh: none.
  Vec3 size = Vec3::Zero();
  std::shared_ptr<const TriangleMesh> mesh;  // kMesh
};

struct Obstacle {
  std::string name;
  ObstacleShape shape;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();  // obstacle frame in the world
  double friction = 0.5;                                   // Coulomb coefficient with rods
  bool moving = false;  // its pose may change while the scene runs (robot links)
  // False: kept in its slot (the other obstacles' indices stay) but touched by no query; how an
  // obstacle removed at run time leaves the set.
  bool enabled = true;
  // A moving obstacle's velocity (world frame): of its frame's origin and its angular velocity.
  // Contacts constrain the rod's velocity relative to the obstacle's surface point.
  Vec3 linear_velocity = Vec3::Zero();
  Vec3 angular_velocity = Vec3::Zero();

  // The velocity of the obstacle's material point at p (world).
  Vec3 velocity_at(const Vec3& p) const {
    return linear_velocity + angular_velocity.cross(p - pose.translation());
  }
};

// Closest points between a rod segment's axis [a, b] and an obstacle's surface. Always
// on_obstacle + distance * normal = a + s (b - a): outside, the normal points from the surface to
// the axis; inside (distance < 0), it is the surface's outward normal at the nearest surface
// point of the deepest axis point (the direction that takes the axis out).
//
// Per kind: plane, sphere, capsule, box, cylinder: exact (the deepest axis point when inside).
// Mesh: outside, the closest pair; an axis inside a closed mesh (every edge shared by two
// triangles) without crossing its surface gets its negative distance; an axis crossing the
// surface is reported at a crossing point with distance 0 and that triangle's normal (by its
// winding: counter-clockwise seen from outside), FCL giving meshes no penetration depth.
struct SegmentContact {
  double distance = 0.0;            // from the axis to the surface (negative: the axis is inside)
  double s = 0.0;                   // the point on the axis: a + s (b - a), s in [0, 1]
  Vec3 on_obstacle = Vec3::Zero();  // closest point on the obstacle's surface (world)
  Vec3 normal = Vec3::UnitZ();      // unit, from the obstacle towards the axis (world)
};

// The obstacles of a scene with what the queries need prepared once (FCL objects and their
// bounding boxes). Not copyable cheaply: hold it by pointer.
class ObstacleSet {
 public:
  ObstacleSet();
  ~ObstacleSet();
  ObstacleSet(const ObstacleSet&) = delete;
  ObstacleSet& operator=(const ObstacleSet&) = delete;

  // Throws std::invalid_argument for a bad shape (non-positive or non-finite size, an empty mesh,
  // a triangle index out of range, a non-finite pose or one that is not a rotation, a negative
  // friction), naming the obstacle. A capsule's length may be 0 (a sphere).
  int add(const Obstacle& obstacle);
  // Puts `obstacle` in slot i instead of what it holds (shape, pose, everything): the other
  // indices stay. Throws as add() (then slot i is unchanged), std::out_of_range for a bad index.
  void replace(int i, const Obstacle& obstacle);
  int size() const;
  const Obstacle& obstacle(int i) const;
  // Moves obstacle i (its bounding boxes are refreshed). Throws std::out_of_range for a bad
  // index, std::invalid_argument for a pose as add() refuses.
  void set_pose(int i, const Eigen::Isometry3d& pose);
  // Moves obstacle i and sets its velocity (world frame: origin's linear and angular velocity).
  // Throws as set_pose, and std::invalid_argument for a non-finite velocity.
  void set_pose(int i, const Eigen::Isometry3d& pose, const Vec3& linear_velocity,
                const Vec3& angular_velocity);

  // Every obstacle whose surface is within `reach` of the segment's axis [a, b]: appends one
  // closest-point pair per such obstacle to `out` (with `which` the obstacle's index; `which` may
  // be null). A moving obstacle's reach grows by what its surface can travel in `h` seconds at its
  // velocity (the largest speed of its surface: the origin's speed plus the angular speed times
  // the farthest point of its bounding box; a plane: its speed along its normal plus the angular
  // speed times the segment's farthest end from its origin), so that a step of h finds it.
  // Bounding boxes first (the obstacle's own box in the world grown by the reach; for a plane, the
  // end points' heights), then the exact query. Primitives and planes allocate nothing
  // but `out`'s and `which`'s growth; meshes allocate inside FCL (about 4 times per query
  // measured). Concurrent queries are safe (no set_pose or add meanwhile).
  void query(const Vec3& a, const Vec3& b, double reach, std::vector<SegmentContact>* out,
             std::vector<int>* which, double h = 0.0) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace corde
