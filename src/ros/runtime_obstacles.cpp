#include "corde_sim/ros/runtime_obstacles.h"

#include <cmath>
#include <memory>
#include <stdexcept>

#include "corde_sim/contact/obstacle_checks.h"
#include "corde_sim/ros/input_checks.h"

namespace corde_sim {
namespace {

using Kind = corde::ObstacleShape::Kind;

[[noreturn]] void fail(const std::string& why) { throw std::invalid_argument(why); }

// A primitive's dimension: positive, finite, at most kMaxObstacleLength.
double dimension(const ObstacleRequest& r, size_t i, const char* what) {
  const double v = r.dimensions[i];
  if (!(std::isfinite(v) && v > 0.0 && v <= kMaxObstacleLength))
    fail("primitive.dimensions[" + std::to_string(i) + "] (" + what + ") is " + num(v) +
         ": must be > 0 and at most " + num(kMaxObstacleLength) + " m");
  return v;
}

}  // namespace

const char* shape_kind_name(Kind kind) {
  switch (kind) {
    case Kind::kPlane:
      return "plane";
    case Kind::kBox:
      return "box";
    case Kind::kSphere:
      return "sphere";
    case Kind::kCylinder:
      return "cylinder";
    case Kind::kCapsule:
      return "capsule";
    case Kind::kMesh:
      return "mesh";
  }
  return "unknown";
}

corde::Obstacle obstacle_from_request(const ObstacleRequest& r) {
  if (r.name.empty()) fail("name is empty");
  const std::string long_name = check_name_length(r.name, "name");
  if (!long_name.empty()) fail(long_name);
  corde::Obstacle o;
  o.name = r.name;
  Eigen::Quaterniond q = r.orientation;
  const std::string pose = check_pose(r.position, &q);
  if (!pose.empty()) fail("pose: " + pose);
  o.pose.linear() = q.toRotationMatrix();
  o.pose.translation() = r.position;
  if (!(std::isfinite(r.friction) && r.friction >= 0.0 && r.friction <= kMaxObstacleFriction))
    fail("friction is " + num(r.friction) + ": must be >= 0 and at most " +
         num(kMaxObstacleFriction));
  o.friction = r.friction;

  const bool primitive = r.primitive_type != kNoPrimitive;
  const bool mesh = !r.vertices.empty() || !r.triangles.empty();
  const bool plane = r.plane != Eigen::Vector4d::Zero();
  const int given = primitive + mesh + plane;
  if (given == 0)
    fail("no shape: give a primitive (type BOX, SPHERE or CYLINDER), a mesh or a plane");
  if (given > 1) fail("more than one shape: give only one of primitive, mesh and plane");

  if (primitive) {
    auto need = [&](size_t n, const char* which) {
      if (r.dimensions.size() != n)
        fail(std::string("primitive ") + which + " needs " + std::to_string(n) +
             " dimensions, got " + std::to_string(r.dimensions.size()));
    };
    switch (r.primitive_type) {
      case kBox:
        need(3, "BOX");
        o.shape.kind = Kind::kBox;
        o.shape.size = {dimension(r, 0, "x"), dimension(r, 1, "y"), dimension(r, 2, "z")};
        break;
      case kSphere:
        need(1, "SPHERE");
        o.shape.kind = Kind::kSphere;
        o.shape.size.x() = dimension(r, 0, "radius");
        break;
      case kCylinder:
        // shape_msgs: [height, radius]; ours: radius in x, length along z in y.
        need(2, "CYLINDER");
        o.shape.kind = Kind::kCylinder;
        o.shape.size.x() = dimension(r, 1, "radius");
        o.shape.size.y() = dimension(r, 0, "height");
        break;
      case kCone:
        fail("primitive type CONE (4) is not supported: give a mesh");
      default:
        fail("primitive type " + std::to_string(r.primitive_type) +
             " is unknown (BOX 1, SPHERE 2, CYLINDER 3)");
    }
  } else if (mesh) {
    if (r.triangles.empty()) fail("mesh has vertices but no triangles");
    if (r.triangles.size() > kMaxMeshTriangles)
      fail("mesh has " + std::to_string(r.triangles.size()) + " triangles, more than " +
           std::to_string(kMaxMeshTriangles));
    if (r.vertices.size() > kMaxMeshVertices)
      fail("mesh has " + std::to_string(r.vertices.size()) + " vertices, more than " +
           std::to_string(kMaxMeshVertices));
    auto m = std::make_shared<corde::TriangleMesh>();
    m->vertices.reserve(r.vertices.size());
    for (size_t i = 0; i < r.vertices.size(); ++i) {
      const Eigen::Vector3d& v = r.vertices[i];
      if (!(v.allFinite() && v.cwiseAbs().maxCoeff() <= kMaxObstacleLength))
        fail("mesh.vertices[" + std::to_string(i) + "] is not finite or beyond " +
             num(kMaxObstacleLength) + " m");
      m->vertices.push_back(v);
    }
    m->triangles.reserve(r.triangles.size());
    for (size_t t = 0; t < r.triangles.size(); ++t) {
      for (uint32_t k : r.triangles[t])
        if (k >= r.vertices.size())
          fail("mesh.triangles[" + std::to_string(t) + "] has vertex index " + std::to_string(k) +
               ", beyond the " + std::to_string(r.vertices.size()) + " vertices");
      m->triangles.emplace_back(static_cast<int>(r.triangles[t][0]),
                                static_cast<int>(r.triangles[t][1]),
                                static_cast<int>(r.triangles[t][2]));
    }
    o.shape.kind = Kind::kMesh;
    o.shape.mesh = m;
  } else {
    if (!r.plane.allFinite()) fail("plane.coef is not finite");
    const Eigen::Vector3d n = r.plane.head<3>();
    const double len = n.norm();
    if (!(len > 0.0)) fail("plane.coef has no normal (a, b, c all 0)");
    // The plane's own frame: z along the unit normal, origin the plane's point nearest the
    // request frame's origin.
    Eigen::Isometry3d in_pose = Eigen::Isometry3d::Identity();
    const Eigen::Vector3d u = n / len;
    in_pose.linear() = Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), u)
                           .normalized()
                           .toRotationMatrix();
    in_pose.translation() = -(r.plane[3] / len) * u;
    if (!(in_pose.translation().cwiseAbs().maxCoeff() <= kMaxObstacleLength))
      fail("plane.coef places the plane beyond " + num(kMaxObstacleLength) + " m");
    o.shape.kind = Kind::kPlane;
    o.pose = o.pose * in_pose;
  }
  return o;
}

int RuntimeObstacles::find(const std::string& name) const {
  for (size_t k = 0; k < entries_.size(); ++k)
    if (entries_[k].obstacle.name == name) return static_cast<int>(k);
  return -1;
}

bool RuntimeObstacles::add(corde::ObstacleSet* set, corde::Obstacle o, const std::string& frame,
                           const Eigen::Isometry3d& frame_pose, double stamp, bool replace) {
  const int k = find(o.name);
  if (k >= 0 && !replace)
    fail("an obstacle named '" + clip(o.name) +
         "' was added already: remove it first, or set replace to change or move it");
  for (int i = 0; i < set->size(); ++i) {
    const corde::Obstacle& other = set->obstacle(i);
    if (other.enabled && other.name == o.name && (k < 0 || entries_[k].index != i))
      fail("'" + clip(o.name) +
           "' names an obstacle of the scene or the robot: run-time obstacles need names of "
           "their own");
  }
  if (k < 0 && static_cast<int>(entries_.size()) >= kMaxRuntimeObstacles)
    fail("there are " + std::to_string(entries_.size()) + " run-time obstacles already, the limit");
  Entry e;
  e.frame = frame;
  e.frame_pose = frame_pose;
  e.last_stamp = stamp;
  e.obstacle = o;
  corde::Obstacle placed = o;
  placed.pose = frame_pose * o.pose;
  placed.moving = !frame.empty();  // it follows its frame
  const std::string far = corde::check_placed_extent(placed, kMaxObstacleExtent);
  if (!far.empty()) fail(far + " in the world frame");
  e.glide.reset(placed.pose);
  if (k >= 0) {
    e.index = entries_[k].index;
    set->replace(e.index, placed);  // throws before changing anything
    entries_[k] = std::move(e);
    return true;
  }
  if (!free_.empty()) {
    e.index = free_.back();
    set->replace(e.index, placed);
    free_.pop_back();
  } else {
    e.index = set->add(placed);
  }
  entries_.push_back(std::move(e));
  return false;
}

void RuntimeObstacles::remove(corde::ObstacleSet* set, const std::string& name) {
  const int k = find(name);
  if (k < 0) fail("no run-time obstacle is named '" + clip(name) + "'");
  const int index = entries_[k].index;
  if (index >= 0) {
    corde::Obstacle off = set->obstacle(index);
    off.enabled = false;
    off.linear_velocity.setZero();
    off.angular_velocity.setZero();
    set->replace(index, off);
    free_.push_back(index);
  }
  entries_.erase(entries_.begin() + k);
}

void RuntimeObstacles::install(corde::ObstacleSet* set) {
  free_.clear();
  for (Entry& e : entries_) {
    corde::Obstacle placed = e.obstacle;
    placed.pose = e.glide.pose();
    placed.moving = !e.frame.empty();
    e.velocity_given = false;
    e.index = set->add(placed);
  }
}

bool RuntimeObstacles::set_frame_pose(int k, const Eigen::Isometry3d& frame_pose, double interval,
                                      double max_speed, double max_angular_speed, double max_lag) {
  Entry& e = entries_[k];
  e.frame_pose = frame_pose;
  return e.glide.glide_to(frame_pose * e.obstacle.pose, interval, max_speed, max_angular_speed,
                          max_lag);
}

void RuntimeObstacles::before_step(corde::ObstacleSet* set, double h) {
  for (Entry& e : entries_)
    if (e.index >= 0) glide_step(set, e.index, &e.glide, &e.velocity_given, h);
}

}  // namespace corde_sim
