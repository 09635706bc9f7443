// Scene keys for contacts: obstacles (primitives and URDF files), the solver's settings and each
// rod's contact options (docs/scene_format.md, "Obstacles and contacts").
#include <cmath>
#include <map>

#include "corde_sim/urdf_obstacles.h"
#include "scene_reader.h"

namespace corde {
namespace scene_detail {
namespace {

// A pose from `position` and one of `orientation` (quaternion [x, y, z, w]) or `rpy` (roll, pitch,
// yaw about fixed x, y, z, as in URDF); a plane may give its `normal` instead.
Eigen::Isometry3d read_pose(Map* m, bool normal_ok) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  if (auto p = m->find("position")) pose.translation() = p->vec3();
  int given = m->has("orientation") + m->has("rpy") + (normal_ok && m->has("normal"));
  if (given > 1)
    m->fail(normal_ok ? "give one of orientation, rpy or normal"
                      : "give either orientation or rpy");
  if (auto q = m->find("orientation")) {
    pose.linear() = q->quaternion().toRotationMatrix();
  } else if (auto r = m->find("rpy")) {
    const Vec3 a = r->vec3();
    pose.linear() =
        (Eigen::AngleAxisd(a.z(), Vec3::UnitZ()) * Eigen::AngleAxisd(a.y(), Vec3::UnitY()) *
         Eigen::AngleAxisd(a.x(), Vec3::UnitX()))
            .toRotationMatrix();
  } else if (normal_ok) {
    if (auto n = m->find("normal"))
      pose.linear() =
          Quat::FromTwoVectors(Vec3::UnitZ(), n->nonzero_vec3().normalized()).toRotationMatrix();
  }
  return pose;
}

void add(ObstacleSet* set, const Obstacle& o, const Value& where) {
  try {
    set->add(o);
  } catch (const std::exception& e) {
    where.fail(e.what());
  }
}

}  // namespace

void read_obstacles(const Value& list, World* world, const std::string& base) {
  if (!list.is_sequence()) list.fail("expected a list of obstacles, got " + list.describe());
  if (list.node().size() > static_cast<size_t>(SceneLimits::max_items))
    list.fail("has " + std::to_string(list.node().size()) + " obstacles, more than the limit of " +
              std::to_string(SceneLimits::max_items));
  if (!world->obstacles) world->obstacles = std::make_shared<ObstacleSet>();
  int index = 0;
  for (const Value& item : list.items()) {
    Map m(item);
    const std::string name =
        m.has("name") ? m.get("name").string() : "obstacle" + std::to_string(index);
    ++index;
    double friction = 0.5;
    if (auto f = m.find("friction")) friction = f->non_negative();
    bool moving = false;
    if (auto mv = m.find("moving")) moving = mv->boolean();
    if (m.has("urdf")) {
      if (m.has("type")) m.fail("give either type or urdf");
      const Value file = m.get("urdf");
      std::map<std::string, double> joints;
      if (auto j = m.find("joints")) {
        if (!j->is_map()) j->fail("expected a map of joint names to values, got " + j->describe());
        for (const auto& kv : j->node())
          joints[kv.first.as<std::string>()] =
              Value(kv.second, j->path() + "." + kv.first.as<std::string>()).number();
      }
      const Eigen::Isometry3d base_pose = read_pose(&m, false);
      m.finish();
      std::vector<Obstacle> parts;
      try {
        // package:// and file:// names as in URDF files; plain relative ones from the scene's
        // folder.
        parts = load_urdf_obstacles(resolve_resource_path(file.string(), base), joints);
      } catch (const std::exception& e) {
        file.fail(e.what());
      }
      for (Obstacle& o : parts) {
        o.name = name + "/" + o.name;
        o.pose = base_pose * o.pose;
        o.friction = friction;
        o.moving = moving;
        add(world->obstacles.get(), o, item);
      }
      continue;
    }
    Obstacle o;
    o.name = name;
    o.friction = friction;
    o.moving = moving;
    const std::string type =
        m.get("type").choice({"plane", "box", "sphere", "cylinder", "capsule"});
    o.pose = read_pose(&m, type == "plane");
    using K = ObstacleShape::Kind;
    if (type == "plane") {
      o.shape.kind = K::kPlane;
    } else if (type == "box") {
      o.shape.kind = K::kBox;
      const Value size = m.get("size");
      o.shape.size = size.vec3();
      if (!(o.shape.size.minCoeff() > 0.0)) size.fail("every side must be > 0");
    } else {
      o.shape.kind = type == "sphere"     ? K::kSphere
                     : type == "cylinder" ? K::kCylinder
                                          : K::kCapsule;
      o.shape.size.x() = m.get("radius").positive();
      if (type != "sphere") o.shape.size.y() = m.get("length").positive();
    }
    m.finish();
    add(world->obstacles.get(), o, item);
  }
}

void read_contact_settings(const Value& v, ContactSettings* s) {
  Map m(v);
  if (auto p = m.find("iterations")) s->iterations = p->integer(1, 10000);
  if (auto p = m.find("friction")) s->friction = p->non_negative();
  if (auto p = m.find("skin")) s->skin = p->non_negative();
  if (auto p = m.find("push_out")) {
    s->push_out = p->non_negative();
    if (s->push_out > 1.0) p->fail("must be <= 1");
  }
  if (auto p = m.find("max_push_speed")) s->max_push_speed = p->non_negative();
  m.finish();
}

void read_rod_contact(const Value& v, ContactOptions* o) {
  Map m(v);
  if (auto p = m.find("self")) o->self = p->boolean();
  if (auto p = m.find("rods")) o->rods = p->boolean();
  if (auto p = m.find("obstacles")) o->obstacles = p->boolean();
  if (auto p = m.find("friction")) o->friction = p->non_negative();
  m.finish();
}

}  // namespace scene_detail
}  // namespace corde
