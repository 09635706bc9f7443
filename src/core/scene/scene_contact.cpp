// Scene keys for contacts: obstacles (primitives and URDF files, fixed or keyframed), the solver's
// settings and each rod's contact options (docs/scene_format.md, "Obstacles and contacts").
#include <algorithm>
#include <cmath>
#include <map>
#include <optional>

#include "corde_sim/contact/urdf_obstacles.h"
#include "corde_sim/scene/obstacle_checks.h"
#include "scene_reader.h"

namespace corde {
namespace scene_detail {
namespace {

// A pose from `position` and one of `orientation` (quaternion [x, y, z, w]) or `rpy` (roll, pitch,
// yaw about fixed x, y, z, as in URDF); a plane may give its `normal` instead.
Eigen::Isometry3d read_pose(Map* m, bool normal_ok) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  if (auto p = m->find("position")) pose.translation() = p->vec3(SceneBounds::max_length, "m");
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

int add(ObstacleSet* set, const Obstacle& o, const Value& where) {
  try {
    return set->add(o);
  } catch (const std::exception& e) {
    where.fail(e.what());
  }
}

// An entry's keyframed motion (the keys of keyframed drives): the frame at `pose` moves about its
// own origin, `turns` about its z axis (a cylinder's or capsule's axis, a plane's normal).
std::shared_ptr<const Motion> read_obstacle_motion(Map* m, const Eigen::Isometry3d& pose,
                                                   const std::string& base) {
  MotionStart start;
  start.position = pose.translation();
  start.orientation = Quat(pose.linear()).normalized();
  start.tangent = pose.linear().col(2);
  return read_motion(m, start, base);
}

// A URDF entry's `joint_motion`: per joint, keyframes of its value ({time, value}; a keyframe
// without a value keeps the one before) or the shortcut move_by (a change of the value) over
// ramp_time from start_time; interpolation as for drives. Each motion's displacement x is the
// change of the joint's value from `start` (its `joints` value, else 0).
std::map<std::string, std::shared_ptr<const Motion>> read_joint_motions(
    const Value& v, const std::map<std::string, double>& start) {
  if (!v.is_map()) v.fail("expected a map of joint names to motions, got " + v.describe());
  std::map<std::string, std::shared_ptr<const Motion>> out;
  for (const auto& kv : v.node()) {
    const std::string joint = kv.first.as<std::string>();
    Map m(Value(kv.second, v.path() + "." + joint));
    const auto s = start.find(joint);
    const double q0 = s == start.end() ? 0.0 : s->second;
    auto how = [&](Motion::Interpolation fallback) {
      auto p = m.find("interpolation");
      if (!p) return fallback;
      const std::string c = p->choice({"smooth", "stop", "linear"});
      return c == "smooth" ? Motion::Interpolation::kSmooth
             : c == "stop" ? Motion::Interpolation::kStop
                           : Motion::Interpolation::kLinear;
    };
    if (auto kv_frames = m.find("keyframes")) {
      for (const char* k : {"move_by", "ramp_time", "start_time"})
        if (m.has(k)) kv_frames->fail(std::string("give either keyframes or ") + k);
      if (!kv_frames->is_sequence() || kv_frames->node().size() == 0)
        kv_frames->fail("expected a non-empty list of keyframes, got " + kv_frames->describe());
      if (kv_frames->node().size() > static_cast<size_t>(SceneLimits::max_items))
        kv_frames->fail("more than the limit of " + std::to_string(SceneLimits::max_items) +
                        " keyframes");
      std::vector<Keyframe> frames;
      Keyframe previous;
      for (const Value& item : kv_frames->items()) {
        Map f(item);
        Keyframe k = previous;
        k.time = f.get("time").non_negative();
        if (auto p = f.find("value")) k.displacement.x() = p->number() - q0;
        f.finish();
        frames.push_back(k);
        previous = k;
      }
      const Motion::Interpolation interpolation = how(Motion::Interpolation::kSmooth);
      m.finish();
      try {
        out[joint] = std::make_shared<Motion>(std::move(frames), interpolation);
      } catch (const std::invalid_argument& e) {
        kv_frames->fail(e.what());
      }
      continue;
    }
    if (!m.has("move_by")) m.fail("needs keyframes or move_by");
    const double d = m.get("move_by").number();
    if (!m.has("ramp_time"))
      throw SceneError(m.path() + ".ramp_time: missing (required with move_by)");
    const double ramp = m.get("ramp_time").positive();
    double t0 = 0.0;
    if (auto p = m.find("start_time")) t0 = p->non_negative();
    const Motion::Interpolation interpolation = how(Motion::Interpolation::kStop);
    m.finish();
    out[joint] = std::make_shared<Motion>(
        Motion::ramp(t0, ramp, Vec3(d, 0, 0), 0.0, Vec3::UnitZ(), interpolation));
  }
  return out;
}

}  // namespace

void read_obstacles(const Value& list, std::vector<Obstacle>* obstacles,
                    std::vector<ObstacleMotion>* motions, const std::string& base,
                    std::vector<std::string>* paths) {
  if (!list.is_sequence()) list.fail("expected a list of obstacles, got " + list.describe());
  if (list.node().size() > static_cast<size_t>(SceneLimits::max_items))
    list.fail("has " + std::to_string(list.node().size()) + " obstacles, more than the limit of " +
              std::to_string(SceneLimits::max_items));
  // Each obstacle as an ObstacleSet accepts it (the set is the judge of its shape and pose).
  ObstacleSet set;
  auto add_obstacle = [&](const Obstacle& o, const Value& where) {
    const int i = add(&set, o, where);
    obstacles->push_back(o);
    return i;
  };
  // The entry of each obstacle added (a URDF adds several).
  std::string last;
  auto note = [&] {
    if (paths) paths->resize(static_cast<size_t>(set.size()), last);
  };
  int index = 0;
  for (const Value& item : list.items()) {
    note();
    last = item.path();
    Map m(item);
    const std::string name =
        m.has("name") ? m.get("name").string() : "obstacle" + std::to_string(index);
    ++index;
    double friction = 0.5;
    if (auto f = m.find("friction")) friction = f->non_negative(SceneBounds::max_factor, "");
    bool moving = false;
    std::optional<Value> moving_key = m.find("moving");
    if (moving_key) moving = moving_key->boolean();
    // A keyframed obstacle moves: `moving: false` beside keyframes is a contradiction.
    auto keyframed = [&](bool driven) {
      if (driven && moving_key && !moving) moving_key->fail("false, but the obstacle is keyframed");
      return driven;
    };
    if (m.has("urdf")) {
      if (m.has("type")) m.fail("give either type or urdf");
      const Value file = m.get("urdf");
      if (file.string().empty()) file.fail("the path is empty");
      std::map<std::string, double> joints;
      if (auto j = m.find("joints")) {
        if (!j->is_map()) j->fail("expected a map of joint names to values, got " + j->describe());
        for (const auto& kv : j->node())
          joints[kv.first.as<std::string>()] =
              Value(kv.second, j->path() + "." + kv.first.as<std::string>()).number();
      }
      const Eigen::Isometry3d base_pose = read_pose(&m, false);
      const std::shared_ptr<const Motion> motion = read_obstacle_motion(&m, base_pose, base);
      // Joint values over time: the start values and each moving joint's motion.
      struct JointDrive {
        std::map<std::string, double> start;
        std::map<std::string, std::shared_ptr<const Motion>> motions;
      };
      auto drive = std::make_shared<JointDrive>();
      std::optional<Value> joint_key = m.find("joint_motion");
      if (joint_key) drive->motions = read_joint_motions(*joint_key, joints);
      const bool driven = keyframed(motion || !drive->motions.empty());
      m.finish();
      drive->start = joints;
      // Joints that move are named to the loader too, so that a name the robot lacks is an error.
      std::map<std::string, double> named = joints;
      for (const auto& kv : drive->motions) named.emplace(kv.first, 0.0);
      std::vector<Obstacle> parts;
      std::vector<UrdfChain> chains;
      try {
        // package:// and file:// names as in URDF files; plain relative ones from the scene's
        // folder.
        parts = load_urdf_obstacles(resolve_resource_path(file.string(), base), named, &chains);
      } catch (const std::exception& e) {
        file.fail(e.what());
      }
      for (const auto& kv : drive->motions) {
        bool moves_a_link = false;
        for (const UrdfChain& c : chains)
          for (const UrdfChain::Joint& j : c.joints)
            moves_a_link |= j.name == kv.first && j.type != UrdfChain::Joint::Type::kFixed;
        if (!moves_a_link)
          Value(joint_key->node()[kv.first], joint_key->path() + "." + kv.first)
              .fail("joint '" + kv.first +
                    "' is not a revolute, continuous or prismatic joint above a collision element");
      }
      for (size_t p = 0; p < parts.size(); ++p) {
        Obstacle& o = parts[p];
        bool follows_joints = false;
        for (const UrdfChain::Joint& j : chains[p].joints)
          follows_joints |= drive->motions.count(j.name) > 0;
        const Eigen::Isometry3d link = o.pose;
        o.name = name + "/" + o.name;
        o.pose = base_pose * link;
        o.friction = friction;
        // Marked moving by the URDF (behind a movable joint) only if asked to or driven.
        o.moving = moving || motion || follows_joints;
        const int i = add_obstacle(o, item);
        if (!driven) continue;
        ObstacleMotion om;
        om.obstacle = i;
        om.motion = motion;
        om.start = base_pose;
        om.local = link;
        if (follows_joints)
          om.local_at = [drive, chain = chains[p]](double t) {
            return chain.pose([&](const std::string& joint) {
              const auto s = drive->start.find(joint);
              double q = s == drive->start.end() ? 0.0 : s->second;
              const auto m = drive->motions.find(joint);
              if (m != drive->motions.end()) q += m->second->at(t).displacement.x();
              return q;
            });
          };
        if (motion || follows_joints) motions->push_back(std::move(om));
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
      o.shape.size = size.vec3(SceneBounds::max_length, "m");
      if (!(o.shape.size.minCoeff() > 0.0)) size.fail("every side must be > 0");
    } else {
      o.shape.kind = type == "sphere"     ? K::kSphere
                     : type == "cylinder" ? K::kCylinder
                                          : K::kCapsule;
      o.shape.size.x() = m.get("radius").positive(SceneBounds::max_length, "m");
      if (type != "sphere")
        o.shape.size.y() = m.get("length").positive(SceneBounds::max_length, "m");
    }
    const std::shared_ptr<const Motion> motion = read_obstacle_motion(&m, o.pose, base);
    o.moving = moving || keyframed(motion != nullptr);
    m.finish();
    const int i = add_obstacle(o, item);
    if (motion) {
      ObstacleMotion om;
      om.obstacle = i;
      om.motion = motion;
      om.start = o.pose;
      motions->push_back(std::move(om));
    }
  }
  note();
}

void check_obstacle_placement(const std::vector<Obstacle>& obstacles,
                              const std::vector<std::string>& paths) {
  // Every obstacle as placed (URDF links too, posed through their chains): far beyond the bounds
  // of the scene's keys, the geometry queries fail ("too many iterations in Jacobi transform").
  for (size_t i = 0; i < obstacles.size(); ++i) {
    const std::string why = obstacle_placement_error(obstacles[i]);
    if (!why.empty())
      throw SceneError((i < paths.size() ? paths[i] : std::string("obstacles")) + ": " + why);
  }
}

void check_rods_clear_of_obstacles(const World& world,
                                   const std::vector<std::string>& obstacle_paths,
                                   const std::vector<std::string>& rod_paths) {
  if (!world.obstacles || world.obstacles->size() == 0) return;
  std::vector<SegmentContact> found;
  std::vector<int> which;
  for (size_t r = 0; r < world.rods().size(); ++r) {
    const Rod& rod = world.rods()[r];
    if (!rod.contact_options().obstacles) continue;
    const double radius = rod.section().radius;
    const auto& x = rod.positions();
    double worst = 0.01 * radius;  // touching, within 1% of the radius, is a start on the surface
    int seg = -1, obstacle = -1;
    for (int s = 0; s < rod.num_segments(); ++s) {
      found.clear();
      which.clear();
      world.obstacles->query(x[s], x[s + 1], radius, &found, &which);
      for (size_t k = 0; k < found.size(); ++k)
        if (radius - found[k].distance > worst)
          worst = radius - found[k].distance, seg = s, obstacle = which[k];
    }
    if (obstacle < 0) continue;
    const std::string entry =
        static_cast<size_t>(obstacle) < obstacle_paths.size() ? obstacle_paths[obstacle] : "";
    throw SceneError(rod_paths[r] + ": rod '" + rod.name() + "' starts inside obstacle '" +
                     world.obstacles->obstacle(obstacle).name + "'" +
                     (entry.empty() ? "" : " (" + entry + ")") + ": segment " +
                     std::to_string(seg) + " is " + num(worst) + " m deep (radius " + num(radius) +
                     " m; a start touching within 1% of the radius is accepted); "
                     "move the rod or the obstacle");
  }
}

void read_contact_settings(const Value& v, ContactSettings* s) {
  Map m(v);
  if (auto p = m.find("iterations")) s->iterations = p->integer(1, 10000);
  if (auto p = m.find("implicit_sweeps")) s->implicit_sweeps = p->integer(1, 10000);
  if (auto p = m.find("implicit_solver"))
    s->implicit_solver = p->choice({"rounds", "delassus"}) == "delassus"
                             ? ContactSettings::Solver::kDelassus
                             : ContactSettings::Solver::kRounds;
  if (auto p = m.find("implicit_iterations")) s->implicit_iterations = p->integer(1, 10000);
  if (auto p = m.find("friction")) s->friction = p->non_negative(SceneBounds::max_factor, "");
  if (auto p = m.find("skin")) s->skin = p->non_negative(SceneBounds::max_skin, "");
  if (auto p = m.find("push_out")) {
    s->push_out = p->non_negative();
    if (s->push_out > 1.0) p->fail("must be <= 1");
  }
  if (auto p = m.find("max_push_speed"))
    s->max_push_speed = p->non_negative(SceneBounds::max_speed, "m/s");
  if (auto p = m.find("push_out_time"))
    s->push_out_time = p->non_negative(SceneBounds::max_time, "s");
  if (auto p = m.find("deep_penetration"))
    s->deep_penetration = p->positive(SceneBounds::max_factor, "");
  if (auto p = m.find("surface_friction")) s->surface_friction = p->boolean();
  if (auto p = m.find("rolling_friction")) {
    s->rolling_friction = p->non_negative();
    if (s->rolling_friction > 1.0) p->fail("must be <= 1");
  }
  m.finish();
}

void read_rod_contact(const Value& v, ContactOptions* o) {
  Map m(v);
  if (auto p = m.find("self")) o->self = p->boolean();
  if (auto p = m.find("rods")) o->rods = p->boolean();
  if (auto p = m.find("obstacles")) o->obstacles = p->boolean();
  if (auto p = m.find("friction")) o->friction = p->non_negative(SceneBounds::max_factor, "");
  m.finish();
}

}  // namespace scene_detail
}  // namespace corde
