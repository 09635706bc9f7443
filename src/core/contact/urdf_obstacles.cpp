// URDF collision geometry as obstacles: urdfdom parses, forward kinematics poses the links,
// assimp reads the mesh files.
#include "corde_sim/contact/urdf_obstacles.h"

#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <console_bridge/console.h>
#include <urdf_parser/urdf_parser.h>

#include <assimp/Importer.hpp>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <regex>
#include <set>
#include <sstream>
#include <stdexcept>

#include "corde_sim/io/file_read.h"
#include "corde_sim/scene/scene.h"
#include "urdf_checks.h"

namespace corde {

namespace fs = std::filesystem;

namespace {

// urdfdom reports why a document fails through console_bridge only: collect its messages while
// parsing (the handler is process-wide, hence the lock; the previous one is restored).
class Collector : public console_bridge::OutputHandler {
 public:
  void log(const std::string& text, console_bridge::LogLevel level, const char*, int) override {
    if (level >= console_bridge::CONSOLE_BRIDGE_LOG_ERROR) {
      if (!text_.empty()) text_ += "; ";
      text_ += text;
    }
  }
  const std::string& text() const { return text_; }

 private:
  std::string text_;
};

struct Parsed {
  urdf::ModelInterfaceSharedPtr model;
  std::map<std::string, int> collisions;  // per link, as the XML has them
  std::string log;                        // urdfdom's error messages
};

Parsed parse(const std::string& xml, const std::string& doc) {
  Parsed out;
  // First our own reading: bounds, and every collision element checked by name.
  out.collisions = check_urdf_xml(xml, doc).collisions;
  static std::mutex mutex;
  std::lock_guard<std::mutex> lock(mutex);
  Collector collector;
  console_bridge::useOutputHandler(&collector);
  std::string error;
  try {
    const urdf::ModelInterfaceSharedPtr model = urdf::parseURDF(xml);
    // Links own their children: a long chain would be destroyed by recursion (100000 links need
    // more than 1 MB of stack); cut the links apart first.
    if (model)
      out.model = urdf::ModelInterfaceSharedPtr(model.get(), [model](urdf::ModelInterface*) {
        for (const auto& kv : model->links_) {
          kv.second->child_links.clear();
          kv.second->child_joints.clear();
        }
      });
  } catch (const std::exception& e) {
    error = e.what();
  }
  console_bridge::restorePreviousOutputHandler();
  out.log = collector.text();
  if (!out.model) {
    if (error.empty()) error = out.log;
    throw std::runtime_error(doc + ": not a valid URDF" + (error.empty() ? "" : ": " + error));
  }
  // urdfdom skips a collision element it cannot read and keeps the model: refuse that here
  // (the checks above should have named it already).
  for (const auto& [name, link] : out.model->links_) {
    const auto it = out.collisions.find(name);
    const int in_xml = it == out.collisions.end() ? 0 : it->second;
    const int read = static_cast<int>(link->collision_array.size());
    if (read != in_xml)
      throw std::runtime_error(doc + ": link '" + name + "': " + std::to_string(in_xml) +
                               " collision element(s), but the URDF parser read " +
                               std::to_string(read) + (out.log.empty() ? "" : ": " + out.log));
  }
  return out;
}

Eigen::Isometry3d to_iso(const urdf::Pose& p) {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.translation() = Vec3(p.position.x, p.position.y, p.position.z);
  Eigen::Quaterniond q(p.rotation.w, p.rotation.x, p.rotation.y, p.rotation.z);
  if (q.norm() > 0.0) t.linear() = q.normalized().toRotationMatrix();
  return t;
}

// The folder of ROS package `pkg`: above `start` (a folder named pkg or whose package.xml names
// it), then in ROS_PACKAGE_PATH's folders and their direct subfolders.
bool package_xml_names(const fs::path& dir, const std::string& pkg) {
  std::ifstream in(dir / "package.xml");
  if (!in) return false;
  std::stringstream text;
  text << in.rdbuf();
  static const std::regex name_re("<name>\\s*([^<\\s]+)\\s*</name>");
  std::smatch m;
  const std::string s = text.str();
  return std::regex_search(s, m, name_re) && m[1] == pkg;
}

fs::path find_package_dir(const std::string& pkg, const fs::path& start) {
  std::error_code ec;
  for (fs::path dir = fs::absolute(start, ec); !dir.empty(); dir = dir.parent_path()) {
    if (dir.filename() == pkg || package_xml_names(dir, pkg)) return dir;
    if (fs::is_directory(dir / pkg, ec)) return dir / pkg;
    if (dir == dir.parent_path()) break;
  }
  if (const char* env = std::getenv("ROS_PACKAGE_PATH")) {
    std::stringstream paths(env);
    std::string entry;
    while (std::getline(paths, entry, ':')) {
      if (entry.empty()) continue;
      const fs::path root(entry);
      if (root.filename() == pkg || package_xml_names(root, pkg)) return root;
      if (fs::is_directory(root / pkg, ec)) return root / pkg;
      for (const auto& sub : fs::directory_iterator(root, ec)) {
        if (sub.is_directory(ec) && package_xml_names(sub.path(), pkg)) return sub.path();
      }
    }
  }
  return {};
}

// "x y z" for messages (Eigen's stream output pads columns).
std::string xyz_text(const Vec3& v) {
  std::ostringstream s;
  s << v.x() << " " << v.y() << " " << v.z();
  return s.str();
}

fs::path resolve_mesh(const std::string& uri, const fs::path& base, const std::string& where) {
  try {
    return resolve_resource_path(uri, base.string());
  } catch (const std::runtime_error& e) {
    throw std::runtime_error(where + ": mesh " + e.what());
  }
}

}  // namespace

std::string resolve_resource_path(const std::string& uri, const std::string& base_dir) {
  const std::string kPackage = "package://", kFile = "file://";
  const fs::path base = base_dir.empty() ? fs::current_path() : fs::path(base_dir);
  if (uri.rfind(kPackage, 0) == 0) {
    const std::string rest = uri.substr(kPackage.size());
    const size_t slash = rest.find('/');
    const std::string pkg = rest.substr(0, slash);
    const fs::path dir = find_package_dir(pkg, base);
    if (dir.empty()) {
      throw std::runtime_error("'" + uri + "': package '" + pkg + "' not found above " +
                               base.string() + " nor in ROS_PACKAGE_PATH");
    }
    return (slash == std::string::npos ? dir : dir / rest.substr(slash + 1)).string();
  }
  fs::path p(uri.rfind(kFile, 0) == 0 ? uri.substr(kFile.size()) : uri);
  return (p.is_absolute() ? p : base / p).string();
}

TriangleMesh load_mesh_file(const std::string& path, const Vec3& scale) {
  std::error_code ec;
  if (!fs::exists(path, ec)) throw std::runtime_error("mesh file '" + path + "' does not exist");
  // Checked before assimp opens it: a FIFO would block, a device or huge file exhaust memory.
  const std::string why = check_input_file(path, "mesh file", SceneLimits::max_mesh_bytes);
  if (!why.empty()) throw std::runtime_error(why);
  Assimp::Importer importer;
  const aiScene* scene = importer.ReadFile(
      path, aiProcess_Triangulate | aiProcess_JoinIdenticalVertices | aiProcess_SortByPType);
  if (!scene || !scene->mRootNode) {
    throw std::runtime_error("mesh file '" + path +
                             "' cannot be read: " + importer.GetErrorString());
  }
  // Every node's meshes with the node's accumulated transform (DAE files place parts by nodes);
  // an explicit stack, as nodes may nest deeply. Nodes may share meshes: the totals are counted
  // before anything is copied.
  std::vector<std::pair<const aiNode*, aiMatrix4x4>> nodes{{scene->mRootNode, aiMatrix4x4()}};
  std::vector<std::pair<const aiMesh*, aiMatrix4x4>> parts;
  long vertices = 0, triangles = 0;
  auto too_many = [&](long n, long limit, const char* what) {
    throw std::runtime_error("mesh file '" + path + "': has " + std::to_string(n) + " " + what +
                             ", more than the limit of " + std::to_string(limit));
  };
  while (!nodes.empty()) {
    const auto [node, parent] = nodes.back();
    nodes.pop_back();
    const aiMatrix4x4 t = parent * node->mTransformation;
    for (unsigned k = 0; k < node->mNumMeshes; ++k) {
      const aiMesh* m = scene->mMeshes[node->mMeshes[k]];
      vertices += m->mNumVertices;
      triangles += m->mNumFaces;
      if (vertices > SceneLimits::max_mesh_vertices)
        too_many(vertices, SceneLimits::max_mesh_vertices, "vertices");
      if (triangles > SceneLimits::max_mesh_triangles)
        too_many(triangles, SceneLimits::max_mesh_triangles, "triangles");
      parts.emplace_back(m, t);
    }
    for (unsigned c = 0; c < node->mNumChildren; ++c) nodes.emplace_back(node->mChildren[c], t);
  }
  TriangleMesh mesh;
  mesh.vertices.reserve(static_cast<size_t>(vertices));
  mesh.triangles.reserve(static_cast<size_t>(triangles));
  for (const auto& [m, t] : parts) {
    const int offset = static_cast<int>(mesh.vertices.size());
    for (unsigned v = 0; v < m->mNumVertices; ++v) {
      const aiVector3D p = t * m->mVertices[v];
      const Vec3 x = Vec3(p.x, p.y, p.z).cwiseProduct(scale);
      // Far-out or broken vertices (a scale of 1e308, NaN in the file) would stop the run at
      // t = 0 in the collision queries instead.
      if (!(x.allFinite() && x.cwiseAbs().maxCoeff() <= SceneLimits::max_length)) {
        std::ostringstream msg;
        msg << "mesh file '" << path << "' with mesh scale " << xyz_text(scale) << ": vertex " << v
            << " at (" << xyz_text(x) << ") is beyond " << SceneLimits::max_length
            << " m (or not finite)";
        throw std::runtime_error(msg.str());
      }
      mesh.vertices.push_back(x);
    }
    for (unsigned f = 0; f < m->mNumFaces; ++f) {
      const aiFace& face = m->mFaces[f];
      if (face.mNumIndices != 3) continue;  // points and lines left by the triangulation
      mesh.triangles.emplace_back(offset + static_cast<int>(face.mIndices[0]),
                                  offset + static_cast<int>(face.mIndices[1]),
                                  offset + static_cast<int>(face.mIndices[2]));
    }
  }
  if (mesh.triangles.empty()) {
    throw std::runtime_error("mesh file '" + path + "' holds no triangles");
  }
  // Mirroring scales (an odd number of negative factors) turn the triangles inside out.
  if (scale.x() * scale.y() * scale.z() < 0.0) {
    for (Eigen::Vector3i& tri : mesh.triangles) std::swap(tri[1], tri[2]);
  }
  return mesh;
}

namespace {

// Movable joints times collision elements behind them, summed over the elements, that `chains`
// may hold: each element's chain repeats the joints above it, so a long chain of movable joints
// with an element on every link would need memory quadratic in its length.
constexpr size_t kMaxChainJoints = 1000000;

// A joint's origin or axis far out or not finite: refused like a collision origin.
void check_joint(const urdf::Joint& joint, const std::string& doc) {
  const urdf::Vector3& p = joint.parent_to_joint_origin_transform.position;
  const urdf::Rotation& r = joint.parent_to_joint_origin_transform.rotation;
  const Vec3 xyz(p.x, p.y, p.z);
  if (!(xyz.allFinite() && xyz.cwiseAbs().maxCoeff() <= SceneLimits::max_length &&
        std::isfinite(r.x) && std::isfinite(r.y) && std::isfinite(r.z) && std::isfinite(r.w))) {
    std::ostringstream msg;
    msg << doc << ": joint '" << joint.name << "': origin xyz (" << xyz_text(xyz) << ") beyond "
        << SceneLimits::max_length << " m or not finite";
    throw std::runtime_error(msg.str());
  }
  if (!(std::isfinite(joint.axis.x) && std::isfinite(joint.axis.y) && std::isfinite(joint.axis.z)))
    throw std::runtime_error(doc + ": joint '" + joint.name + "': the axis is not finite");
}

std::vector<UrdfCollision> collisions_of(const urdf::ModelInterface& model, const std::string& doc,
                                         const fs::path& base,
                                         const std::map<std::string, double>& joint_values,
                                         std::vector<UrdfChain>* chains) {
  for (const auto& [name, value] : joint_values) {
    if (!model.getJoint(name)) {
      throw std::runtime_error(doc + ": joint '" + name +
                               "' (in the joint values) is not in robot '" + model.getName() + "'");
    }
    if (!std::isfinite(value)) {
      throw std::runtime_error(doc + ": joint '" + name + "': the value is not finite");
    }
  }
  std::vector<UrdfCollision> out;
  const urdf::LinkConstSharedPtr root = model.getRoot();
  if (!root) throw std::runtime_error(doc + ": the robot has no root link");
  // urdfdom lets a link be the child of several joints: it would be walked once per parent (a
  // lattice of such links exponentially often), or for ever round a cycle.
  std::map<std::string, std::string> parent_joint;
  for (const auto& [name, joint] : model.joints_) {
    check_joint(*joint, doc);
    const auto [it, fresh] = parent_joint.emplace(joint->child_link_name, name);
    if (!fresh)
      throw std::runtime_error(doc + ": link '" + joint->child_link_name +
                               "' is the child of two joints, '" + it->second + "' and '" + name +
                               "' (the links must form a tree)");
  }

  // Depth first with an explicit stack: a chain of 10000 links overflowed the call stack. `path`
  // holds the movable joints from the root to the visited link, each with the fixed joints above
  // it folded into its origin; `fixed` is the product of the fixed joints since the last one.
  struct Entry {
    const urdf::Link* link;
    Eigen::Isometry3d pose;
    bool moving;
    size_t depth;  // path's length at this link
    bool has_step;
    UrdfChain::Joint step;  // the movable joint above the link, when has_step
    Eigen::Isometry3d fixed;
  };
  std::vector<Entry> stack;
  stack.push_back({root.get(),
                   Eigen::Isometry3d::Identity(),
                   false,
                   0,
                   false,
                   {},
                   Eigen::Isometry3d::Identity()});
  std::vector<UrdfChain::Joint> path;
  std::set<const urdf::Link*> visited;
  size_t chain_joints = 0;
  while (!stack.empty()) {
    Entry e = std::move(stack.back());
    stack.pop_back();
    visited.insert(e.link);
    const urdf::Link& link = *e.link;
    const Eigen::Isometry3d& pose = e.pose;
    path.resize(e.depth - (e.has_step ? 1 : 0));
    if (e.has_step) path.push_back(e.step);
    const auto& collisions = link.collision_array;
    for (size_t i = 0; i < collisions.size(); ++i) {
      const urdf::Collision& col = *collisions[i];
      UrdfCollision item;
      item.link = link.name;
      item.in_link = to_iso(col.origin);
      Obstacle& ob = item.obstacle;
      ob.name = collisions.size() > 1 ? link.name + "/" + std::to_string(i) : link.name;
      const std::string where = doc + ": link '" + link.name + "' collision " + std::to_string(i);
      ob.pose = pose * item.in_link;
      ob.moving = e.moving;
      if (!(ob.pose.matrix().allFinite() &&
            ob.pose.translation().cwiseAbs().maxCoeff() <= SceneLimits::max_length)) {
        std::ostringstream msg;
        msg << where << ": placed at (" << xyz_text(ob.pose.translation()) << "), beyond "
            << SceneLimits::max_length << " m from the root link (or not finite)";
        throw std::runtime_error(msg.str());
      }
      if (!col.geometry) throw std::runtime_error(where + ": no geometry");
      auto positive = [&](double v, const std::string& what) {
        if (!(std::isfinite(v) && v > 0.0 && v <= SceneLimits::max_length)) {
          std::ostringstream msg;
          msg << where << ": " << what << " must be positive, at most " << SceneLimits::max_length
              << " m (got " << v << ")";
          throw std::runtime_error(msg.str());
        }
      };
      switch (col.geometry->type) {
        case urdf::Geometry::BOX: {
          const auto& g = static_cast<const urdf::Box&>(*col.geometry);
          positive(g.dim.x, "box size x");
          positive(g.dim.y, "box size y");
          positive(g.dim.z, "box size z");
          ob.shape.kind = ObstacleShape::Kind::kBox;
          ob.shape.size = Vec3(g.dim.x, g.dim.y, g.dim.z);
          break;
        }
        case urdf::Geometry::SPHERE: {
          const auto& g = static_cast<const urdf::Sphere&>(*col.geometry);
          positive(g.radius, "sphere radius");
          ob.shape.kind = ObstacleShape::Kind::kSphere;
          ob.shape.size = Vec3(g.radius, 0.0, 0.0);
          break;
        }
        case urdf::Geometry::CYLINDER: {
          const auto& g = static_cast<const urdf::Cylinder&>(*col.geometry);
          positive(g.radius, "cylinder radius");
          positive(g.length, "cylinder length");
          ob.shape.kind = ObstacleShape::Kind::kCylinder;
          ob.shape.size = Vec3(g.radius, g.length, 0.0);
          break;
        }
        case urdf::Geometry::MESH: {
          const auto& g = static_cast<const urdf::Mesh&>(*col.geometry);
          const Vec3 scale(g.scale.x, g.scale.y, g.scale.z);
          for (int k = 0; k < 3; ++k) {
            if (!(std::isfinite(scale[k]) && scale[k] != 0.0)) {
              std::ostringstream msg;
              msg << where << ": mesh scale "
                  << "xyz"[k] << " must be finite and non-zero (got " << scale[k] << ")";
              throw std::runtime_error(msg.str());
            }
          }
          const fs::path file = resolve_mesh(g.filename, base, where);
          try {
            ob.shape.mesh = std::make_shared<TriangleMesh>(load_mesh_file(file.string(), scale));
          } catch (const std::runtime_error& e) {
            throw std::runtime_error(where + ": mesh '" + g.filename + "': " + e.what());
          }
          ob.shape.kind = ObstacleShape::Kind::kMesh;
          break;
        }
        default:
          throw std::runtime_error(where + ": unknown geometry type");
      }
      out.push_back(std::move(item));
      if (chains) {
        chain_joints += path.size();
        if (chain_joints > kMaxChainJoints)
          throw std::runtime_error(doc +
                                   ": too many collision elements behind too many movable "
                                   "joints (more than " +
                                   std::to_string(kMaxChainJoints) +
                                   " joints counted once per element behind them)");
        chains->push_back({path, e.fixed * to_iso(col.origin)});
      }
    }
    // Children pushed last first: visited in the URDF's order.
    for (auto j = link.child_joints.rbegin(); j != link.child_joints.rend(); ++j) {
      const urdf::Joint& joint = **j;
      const urdf::LinkConstSharedPtr child = model.getLink(joint.child_link_name);
      if (!child) continue;
      const auto it = joint_values.find(joint.name);
      const double q = it == joint_values.end() ? 0.0 : it->second;
      const Vec3 axis(joint.axis.x, joint.axis.y, joint.axis.z);
      const Eigen::Isometry3d origin = to_iso(joint.parent_to_joint_origin_transform);
      Eigen::Isometry3d motion = Eigen::Isometry3d::Identity();
      bool movable = false;
      UrdfChain::Joint step;
      step.name = joint.name;
      step.origin = e.fixed * origin;
      switch (joint.type) {
        case urdf::Joint::REVOLUTE:
        case urdf::Joint::CONTINUOUS:
          movable = true;
          if (axis.norm() > 0.0) {
            motion.linear() = Eigen::AngleAxisd(q, axis.normalized()).matrix();
            step.type = UrdfChain::Joint::Type::kRevolute;
            step.axis = axis.normalized();
          }
          break;
        case urdf::Joint::PRISMATIC:
          movable = true;
          if (axis.norm() > 0.0) {
            motion.translation() = q * axis.normalized();
            step.type = UrdfChain::Joint::Type::kPrismatic;
            step.axis = axis.normalized();
          }
          break;
        case urdf::Joint::FLOATING:
        case urdf::Joint::PLANAR:
          movable = true;
          break;
        default:
          break;
      }
      const bool has_step = step.type != UrdfChain::Joint::Type::kFixed;
      Entry next{child.get(),
                 pose * origin * motion,
                 e.moving || movable,
                 path.size() + (has_step ? 1 : 0),
                 has_step,
                 {},
                 has_step ? Eigen::Isometry3d::Identity() : Eigen::Isometry3d(e.fixed * origin)};
      if (has_step) next.step = std::move(step);
      stack.push_back(std::move(next));
    }
  }
  // With one root and one parent per link, a link not reached sits on a cycle of joints.
  if (visited.size() != model.links_.size()) {
    for (const auto& [name, link] : model.links_) {
      if (!visited.count(link.get()))
        throw std::runtime_error(doc + ": link '" + name + "' is not connected to the root link '" +
                                 root->name + "' (its joints form a cycle)");
    }
  }
  return out;
}

std::vector<Obstacle> obstacles_of(const urdf::ModelInterface& model, const std::string& doc,
                                   const fs::path& base,
                                   const std::map<std::string, double>& joint_values,
                                   std::vector<UrdfChain>* chains) {
  std::vector<Obstacle> out;
  for (UrdfCollision& c : collisions_of(model, doc, base, joint_values, chains))
    out.push_back(std::move(c.obstacle));
  return out;
}

}  // namespace

std::vector<Obstacle> parse_urdf_obstacles(const std::string& xml, const std::string& base_dir,
                                           const std::map<std::string, double>& joint_values,
                                           std::vector<UrdfChain>* chains) {
  const std::string doc = "<urdf string>";
  const urdf::ModelInterfaceSharedPtr model = parse(xml, doc).model;
  return obstacles_of(*model, doc, base_dir.empty() ? fs::current_path() : fs::path(base_dir),
                      joint_values, chains);
}

std::vector<UrdfCollision> parse_urdf_collisions(const std::string& xml,
                                                 const std::string& base_dir,
                                                 const std::string& doc,
                                                 std::vector<std::string>* link_names) {
  const urdf::ModelInterfaceSharedPtr model = parse(xml, doc).model;
  if (link_names) {
    link_names->clear();
    for (const auto& kv : model->links_) link_names->push_back(kv.first);
  }
  return collisions_of(*model, doc, base_dir.empty() ? fs::current_path() : fs::path(base_dir), {},
                       nullptr);
}

std::vector<Obstacle> load_urdf_obstacles(const std::string& path,
                                          const std::map<std::string, double>& joint_values,
                                          std::vector<UrdfChain>* chains) {
  // Regular files only, bounded: a FIFO blocked for ever, /dev/zero grew memory without end.
  const std::string text = read_input_file(path, "URDF", SceneLimits::max_urdf_bytes);
  const urdf::ModelInterfaceSharedPtr model = parse(text, path).model;
  return obstacles_of(*model, path, fs::path(path).parent_path(), joint_values, chains);
}

}  // namespace corde
