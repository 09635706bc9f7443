// Obstacles from a robot description (URDF): every link's collision elements posed by forward
// kinematics at given joint values. Meshes are read with assimp.
#pragma once

#include <Eigen/Geometry>
#include <map>
#include <string>
#include <vector>

#include "corde_sim/contact/obstacle.h"

namespace corde {

// Reads the URDF file at `path`. Each collision element (box, cylinder, sphere, mesh with its
// scale) becomes one obstacle named "<link>" (or "<link>/<i>", i from 0, when the link has
// several), posed at the link's pose times the collision origin. Link poses: from the root link
// at the identity, joints at `joint_values` (radians or metres by joint name; absent joints at 0;
// revolute and continuous joints rotate about their axis, prismatic ones translate along it;
// fixed, floating and planar joints stay at their origin; mimic joints are not followed).
// Obstacles behind a movable joint are marked `moving`.
//
// Mesh file names: `package://<pkg>/<path>` is looked up in the folders above the URDF's folder
// (a folder named <pkg> or holding a package.xml that names <pkg>), then in ROS_PACKAGE_PATH's
// folders; `file://` and relative names are relative to the URDF's folder.
//
// The file is read with corde::read_input_file (a regular file of at most
// SceneLimits::max_urdf_bytes). Throws std::runtime_error naming the file and the element (link,
// collision index, joint) for a URDF that does not parse, is not XML with a <robot> root, nests
// elements more than 100 deep, has more than SceneLimits::max_urdf_links links, a link that is the
// child of two joints or not connected to the root; a collision element urdfdom would skip (a
// geometry or origin that does not parse, an empty or unknown geometry); a size, mesh scale or
// position that is not finite, not positive (sizes) or zero (scales), or beyond
// SceneLimits::max_length; a missing or unreadable mesh; or a joint name in `joint_values` the
// robot lacks. Links are walked without recursion.
//
// `chains`, when given, receives per obstacle (same order) how it is posed from the joint values,
// for re-posing the links when joints move (UrdfChain::pose).
struct UrdfChain;
std::vector<Obstacle> load_urdf_obstacles(const std::string& path,
                                          const std::map<std::string, double>& joint_values = {},
                                          std::vector<UrdfChain>* chains = nullptr);

// The same from the URDF's text (at most SceneLimits::max_urdf_bytes); relative mesh names are
// resolved against `base_dir`. Messages name the document "<urdf string>".
std::vector<Obstacle> parse_urdf_obstacles(const std::string& xml, const std::string& base_dir,
                                           const std::map<std::string, double>& joint_values = {},
                                           std::vector<UrdfChain>* chains = nullptr);

// Forward kinematics of one URDF obstacle: the joints from the root link to its link, then its
// collision origin. pose(q) = origin_1 M_1(q_1) ... origin_k M_k(q_k) collision, M a rotation
// about the joint's axis (revolute, continuous) or a translation along it (prismatic), identity
// for the other kinds; the result is in the root link's frame.
struct UrdfChain {
  struct Joint {
    enum class Type { kFixed, kRevolute, kPrismatic };
    std::string name;
    Type type = Type::kFixed;
    Eigen::Isometry3d origin = Eigen::Isometry3d::Identity();  // in the parent link's frame
    Vec3 axis = Vec3::UnitZ();                                 // unit, in the joint's frame
  };
  std::vector<Joint> joints;
  Eigen::Isometry3d collision = Eigen::Isometry3d::Identity();
  // `value(name)` gives each movable joint's value (rad or m).
  template <class Value>
  Eigen::Isometry3d pose(const Value& value) const {
    Eigen::Isometry3d p = Eigen::Isometry3d::Identity();
    for (const Joint& j : joints) {
      p = p * j.origin;
      if (j.type == Joint::Type::kRevolute)
        p.rotate(Eigen::AngleAxisd(value(j.name), j.axis));
      else if (j.type == Joint::Type::kPrismatic)
        p.translate(value(j.name) * j.axis);
    }
    return p * collision;
  }
};

// One collision element with the link it belongs to, for following a moving robot: the
// obstacle's pose is link pose * in_link (the collision origin); `obstacle` is posed at the
// root link's identity with every joint at 0 (marked `moving` behind a movable joint).
struct UrdfCollision {
  std::string link;
  Eigen::Isometry3d in_link = Eigen::Isometry3d::Identity();
  Obstacle obstacle;
};

// Every collision element of the URDF text `xml`, checked and read like parse_urdf_obstacles
// (same names, same errors), with messages naming the document `doc` (e.g. "parameter
// robot_description"). `link_names`, if given, receives the names of all the robot's links.
std::vector<UrdfCollision> parse_urdf_collisions(const std::string& xml,
                                                 const std::string& base_dir,
                                                 const std::string& doc,
                                                 std::vector<std::string>* link_names = nullptr);

// A file name as URDF files (and the scene key `urdf`) give them: `package://<pkg>/<path>` (the
// package's folder looked up as for meshes above, starting at `base_dir`), `file://<path>`, an
// absolute path, or a path relative to `base_dir` (empty: the current folder). Throws
// std::runtime_error naming the name when the package is not found.
std::string resolve_resource_path(const std::string& uri, const std::string& base_dir);

// Triangles of a mesh file (STL, DAE, OBJ, ... : what assimp reads), every node's transform
// applied, then scaled per axis. Throws std::runtime_error naming the file when it is not a
// regular file of at most SceneLimits::max_mesh_bytes (checked before assimp opens it), has more
// than SceneLimits::max_mesh_triangles triangles or max_mesh_vertices vertices, or a scaled
// vertex not finite or beyond SceneLimits::max_length.
TriangleMesh load_mesh_file(const std::string& path, const Vec3& scale = Vec3::Ones());

}  // namespace corde
