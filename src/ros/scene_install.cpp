// SceneInstall: a scene into the simulation driver (its world, its grasps with their sources and
// scripts), the robot's links as obstacles, grasps made and let go at run time. The robot's
// URDF collision elements (from a parameter or a file) follow their links' tf frames (NodeInputs).
#include "corde_sim/ros/scene_install.h"

#include <ros/callback_queue.h>
#include <ros/console.h>
#include <ros/package.h>
#include <sys/stat.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "corde_sim/io/file_read.h"
#include "corde_sim/ros/input_checks.h"
#include "corde_sim/ros/sim_node.h"
#include "corde_sim/statics/scene_statics.h"

namespace corde_sim {
namespace {

// Valid as a graph name component, so that grasps/<name>/pose is a legal topic; bounded length.
bool valid_name(const std::string& s) {
  if (s.empty() || s.size() > kMaxNameLength || !std::isalpha(static_cast<unsigned char>(s[0])))
    return false;
  return std::all_of(s.begin(), s.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_';
  });
}

// stat() only: opening a FIFO to test it would block. (Whether it is a usable regular file is
// check_input_file's business, with a message.)
bool file_exists(const std::string& path) {
  struct stat st;
  return stat(path.c_str(), &st) == 0;
}

}  // namespace

std::string SceneInstall::resolve_scene(const std::string& path, std::string* error) const {
  if (path.empty()) {
    *error = "no scene file given";
    return "";
  }
  if (path[0] == '/') {
    if (file_exists(path)) return path;
    *error = "scene file '" + clip(path) + "' does not exist";
    return "";
  }
  // The node's working directory is ROS's (~/.ros), which says nothing to a user: a relative path
  // is looked up in the package and its scene folder.
  const std::string pkg = ros::package::getPath("corde_sim");
  if (!pkg.empty()) {
    for (const std::string& c : {pkg + "/" + path, pkg + "/config/scenes/" + path})
      if (file_exists(c)) return c;
  }
  *error = "scene file '" + clip(path) +
           "' not found: a relative path is looked up in the package" +
           (pkg.empty() ? std::string(" (whose path is unknown)")
                        : " folder " + pkg + " and in " + pkg + "/config/scenes") +
           "; give an absolute path otherwise";
  return "";
}

std::string SceneInstall::install_scene(corde::Scene scene, const std::string& path) {
  // Check every grasp before anything changes, so that a bad scene leaves the node as it was.
  for (const corde::GraspSpec& spec : scene.grasps) {
    try {
      corde::grasp_segment(scene.world.rod(spec.rod), spec);
    } catch (const std::exception& e) {
      return "grasp '" + spec.name + "': " + e.what();
    }
    if (!valid_name(spec.name))
      return "grasp name '" + clip(spec.name) +
             "' is not a valid ROS name ([A-Za-z][A-Za-z0-9_]*, at most " +
             std::to_string(kMaxNameLength) + " characters)";
  }
  const std::string placed = place_at_frames(&scene, !installed_);
  if (!placed.empty()) return placed;
  installed_ = true;
  for (const std::string& w : scene.warnings) ROS_WARN("corde_sim: scene: %s", w.c_str());
  for (const std::string& s : scene.settled) ROS_INFO("corde_sim: scene: %s", s.c_str());
  if (scene.mode == corde::Scene::Mode::kStatics)
    ROS_WARN(
        "corde_sim: scene: mode: statics is for corde_run; the node runs the scene (use "
        "initial_state: equilibrium to start it at rest in equilibrium)");
  for (const std::string& n : scene.notes) ROS_INFO("corde_sim: scene: %s", n.c_str());
  // Whether the guard had stopped the old world (the reply says that the new one resumes).
  guard_note_ = node_.restart_guard();
  // Topics of grasps the new scene has too stay subscribed (a reset does not make publishers
  // reconnect); the others end.
  for (auto it = node_.wiring_.begin(); it != node_.wiring_.end();) {
    const bool kept = std::any_of(scene.grasps.begin(), scene.grasps.end(),
                                  [&](const corde::GraspSpec& g) { return g.name == it->first; });
    if (kept) it->second.scripted = false;  // add_grasp starts its script again
    it = kept ? std::next(it) : node_.wiring_.erase(it);
  }
  node_.sim_.install(scene.world);  // no grasps, scripts or commands; the holder limits stay
  install_robot();                  // the robot's links join the new world's obstacles
  node_.obstacles_.install();       // so do the run-time obstacles
  initial_ = std::move(scene);
  scene_path_ = path;
  node_.settings_ = settings_from_world(node_.world_);
  for (const corde::GraspSpec& spec : initial_.grasps) {
    auto p = node_.params_.grasps.find(spec.name);
    const GraspSource source =
        p == node_.params_.grasps.end() ? GraspSource::kTopic : p->second.source;
    const std::string frame = p == node_.params_.grasps.end() ? "" : p->second.frame;
    int segment = -1;
    const std::string e = add_grasp(spec, source, frame, /*from_scene=*/true, &segment);
    if (!e.empty()) ROS_WARN("corde_sim: scene grasp not made: %s", e.c_str());
  }
  node_.sim_.restart_guard();  // the grasps made are the state to go back to
  node_.outputs_.refresh_layout();
  return "";
}

std::string SceneInstall::place_at_frames(corde::Scene* scene, bool wait) {
  std::vector<std::string> placed_rods;
  for (const corde::GraspSpec& spec : scene->grasps) {
    auto p = node_.params_.grasps.find(spec.name);
    if (p == node_.params_.grasps.end() || !p->second.start_at_frame) continue;
    const GraspSourceParam& param = p->second;
    const std::string what = "parameter ~grasps/" + spec.name + "/start_at_frame";
    corde::Rod& rod = scene->world.rod(spec.rod);  // (install_scene checked the grasps)
    if (std::find(placed_rods.begin(), placed_rods.end(), rod.name()) != placed_rods.end())
      return what + ": rod '" + rod.name() +
             "' is already placed at another grasp's frame; one grasp per rod starts at a frame";
    if (!rod.node_drives().empty() || !rod.segment_drives().empty() ||
        !rod.node_constraints().empty() || !rod.segment_constraints().empty())
      return what + ": rod '" + rod.name() +
             "' has boundary conditions (a clamp, fixed or driven node, or constraint) that a "
             "rigid move to frame '" +
             param.frame + "' would tear; hold it by its grasps only";
    Eigen::Isometry3d frame;
    std::string error;
    const double deadline = wall_seconds() + (wait ? param.start_timeout : 0.0);
    if (wait && !node_.inputs_.lookup_world(param.frame, ros::Time(0), &frame, &error))
      ROS_INFO("corde_sim: grasp '%s' starts at tf frame '%s': waiting up to %g s for it",
               spec.name.c_str(), param.frame.c_str(), param.start_timeout);
    while (!node_.inputs_.lookup_world(param.frame, ros::Time(0), &frame, &error)) {
      if (!wait || wall_seconds() >= deadline || !ros::ok()) {
        char waited[64] = "";
        if (wait) std::snprintf(waited, sizeof waited, " after %g s", param.start_timeout);
        return what + ": tf frame '" + clip(param.frame) + "' not available" + waited + " (" +
               error + "); publish it (e.g. robot_state_publisher) or raise ~grasps/" + spec.name +
               "/start_timeout";
      }
      ros::getGlobalCallbackQueue()->callAvailable(ros::WallDuration(0.02));
    }
    corde::place_rod(rod, corde::grasp_segment(rod, spec),
                     param.has_offset ? frame * param.offset : frame);
    // Statics solves no contacts: the shape hanging from the frame is solved without the
    // scene's obstacles (the run's contacts then push it out of any it reaches).
    const auto obstacles = scene->world.obstacles;
    scene->world.obstacles.reset();
    try {
      const corde::RodEquilibrium e = corde::settle_rod(scene, &rod);
      scene->world.obstacles = obstacles;
      ROS_INFO(
          "corde_sim: grasp '%s' starts at tf frame '%s': rod '%s' placed there and hanging at "
          "rest in static equilibrium (residual %.3g N, %d Newton iterations)",
          spec.name.c_str(), param.frame.c_str(), rod.name().c_str(), e.result.residual,
          e.result.iterations);
    } catch (const std::exception& ex) {
      scene->world.obstacles = obstacles;
      return what + ": rod '" + rod.name() + "' placed at frame '" + param.frame +
             "' has no static equilibrium the node can solve: " + ex.what();
    }
    placed_rods.push_back(rod.name());
  }
  return "";
}

std::string SceneInstall::add_grasp(const corde::GraspSpec& spec, GraspSource source,
                                    const std::string& frame, bool from_scene, int* segment) {
  *segment = -1;
  if (!valid_name(spec.name))
    return "grasp name '" + clip(spec.name) +
           "' is not a valid ROS name ([A-Za-z][A-Za-z0-9_]*, at most " +
           std::to_string(kMaxNameLength) + " characters)";
  if (!valid_frame_chars(frame) || frame.size() > kMaxNameLength)
    return "grasp '" + spec.name + "': frame '" + clip(frame) +
           "' is not a frame id ([A-Za-z0-9_/.-], at most " + std::to_string(kMaxNameLength) +
           " characters)";
  if (source == GraspSource::kTf && frame.empty())
    return "grasp '" + spec.name + "': source tf needs a frame";
  const corde::GraspState* held = node_.grasps_.find(spec.name);
  if (held && held->held)
    return "grasp '" + spec.name + "' already holds rod '" + held->grasp.rod +
           "'; release it first";
  int rod = -1, seg = -1;
  std::string error = node_.grasps_.check(node_.world_, spec, &rod, &seg);
  if (!error.empty()) return "grasp '" + spec.name + "': " + error;

  GraspSourceParam param;
  auto p = node_.params_.grasps.find(spec.name);
  if (p != node_.params_.grasps.end()) param = p->second;
  // Without a frame to follow, the holder starts where the offset puts it relative to the segment
  // (the segment itself when no offset is given): nothing moves.
  const Eigen::Isometry3d segment_start = corde::segment_pose(node_.world_.rods()[rod], seg);
  Eigen::Isometry3d holder = segment_start;
  if (param.has_offset) holder = holder * param.offset.inverse();
  const Eigen::Isometry3d* offset = nullptr;
  bool attached = true;
  if (source == GraspSource::kTf) {
    Eigen::Isometry3d f;
    if (node_.inputs_.lookup_world(frame, ros::Time(0), &f, &error)) {
      holder = f;
      if (param.snap) offset = &param.offset;
    } else if (from_scene) {
      // The frame may not be published yet: hold the segment where it is until it appears.
      attached = false;
      ROS_WARN(
          "corde_sim: grasp '%s' follows tf frame '%s', not available yet (%s); holding the "
          "segment in place until it is",
          spec.name.c_str(), frame.c_str(), error.c_str());
    } else {
      return "grasp '" + spec.name + "': " + error;
    }
  }
  error = node_.grasps_.add(node_.world_, spec, holder, offset, node_.world_.time());
  if (!error.empty()) return "grasp '" + spec.name + "': " + error;

  GraspWiring& w = node_.wiring_[spec.name];
  if (w.marker_id == 0) w.marker_id = ++next_marker_id_;
  w.source = source;
  w.frame = frame;
  w.attached = attached;
  w.has_offset = param.has_offset;
  w.offset = param.offset;
  w.snap = param.snap;
  w.last_input_time = -1.0;
  w.scripted = false;
  const bool timed = spec.grasp_time > 0.0 || std::isfinite(spec.release_time);
  if (from_scene && (spec.motion || timed)) {
    if (source == GraspSource::kTf && attached) {
      // Its frame is there already: an input, which wins over the keyframes.
      ROS_INFO(
          "corde_sim: grasp '%s' follows tf frame '%s' from the start: its scene keyframes, "
          "grasp_time and release_time are not used",
          spec.name.c_str(), frame.c_str());
    } else {
      w.scripted = true;
      w.script_spec = spec;
      node_.sim_.add_script(spec, corde::ScriptDrive::kHolder);  // lets go until grasp_time
      char until[64] = "";
      if (std::isfinite(spec.release_time))
        std::snprintf(until, sizeof until, ", lets go at t = %g s", spec.release_time);
      ROS_INFO(
          "corde_sim: grasp '%s' follows its scene script (takes hold at t = %g s, keyframes to "
          "t = %g s, then holds the last%s) until an input for it arrives",
          spec.name.c_str(), spec.grasp_time,
          spec.grasp_time + (spec.motion ? spec.motion->end_time() : 0.0), until);
    }
  }
  node_.inputs_.wire_grasp(spec.name, &w);
  *segment = seg;
  return "";
}

bool SceneInstall::forget_grasp(const std::string& name) {
  const corde::GraspState* g = node_.grasps_.find(name);
  if (!g || g->held || !g->force.isZero() || !g->torque.isZero()) return false;
  const auto& scene = initial_.grasps;
  if (std::any_of(scene.begin(), scene.end(),
                  [&](const corde::GraspSpec& s) { return s.name == name; }))
    return false;             // the scene's grasps stay listed (and subscribed) until a reset
  node_.wiring_.erase(name);  // its subscriptions and reaction publisher end with it
  node_.grasps_.erase(name);
  return true;
}

void SceneInstall::end_script(const std::string& name, const char* what) {
  auto w = node_.wiring_.find(name);
  if (w == node_.wiring_.end() || !w->second.scripted) return;
  w->second.scripted = false;
  node_.sim_.end_script(name);  // the state to go back to, as the script has ended
  ROS_INFO(
      "corde_sim: grasp '%s' %s: its scene keyframes (and grasp or release time) no longer drive "
      "it (t = %.3f s)",
      name.c_str(), what, node_.sim_time());
}

bool SceneInstall::waiting_to_take_hold(const std::string& name) const {
  return node_.sim_.waiting_to_take_hold(name);
}

void SceneInstall::load_robot() {
  const bool from_file = !node_.params_.robot_urdf_file.empty();
  if (!from_file && !node_.params_.robot_collision) return;
  // A robot asked for explicitly that cannot be read stops the node (like a bad scene): running
  // without some of its links would let them pass through the cable unnoticed.
  std::string xml, base_dir, doc, param;
  if (from_file) {
    param = "robot_urdf_file";
    // Regular files only, bounded (a FIFO would block the node, /dev/zero exhaust its memory).
    try {
      xml = corde::read_input_file(node_.params_.robot_urdf_file, "URDF",
                                   corde::SceneLimits::max_urdf_bytes);
    } catch (const corde::FileError& e) {
      throw std::invalid_argument(std::string("parameter ~robot_urdf_file: ") + e.what());
    }
    base_dir = std::filesystem::path(node_.params_.robot_urdf_file).parent_path().string();
    doc = node_.params_.robot_urdf_file;
  } else {
    param = "robot_collision";
    // Resolved like robot_state_publisher's: relative to the node's namespace.
    const std::string name = node_.nh_.resolveName(node_.params_.robot_description);
    if (!ros::param::get(name, xml))
      throw std::invalid_argument("parameter ~robot_collision: true, but parameter " + name +
                                  " (~robot_description) holds no URDF string");
    doc = "parameter " + name;
  }
  try {
    robot_.load(xml, base_dir, doc, node_.params_.robot_friction, node_.params_.robot_ignore_links);
  } catch (const std::exception& e) {
    throw std::invalid_argument("parameter ~" + param + ": " + e.what());
  }
  if (robot_.empty())
    ROS_WARN("corde_sim: robot collision: %s has no collision elements (outside the ignored links)",
             doc.c_str());
  else
    ROS_INFO(
        "corde_sim: robot collision: %d collision element(s) of %zu link(s) from %s; each takes "
        "part once its tf frame appears",
        robot_.elements(), robot_.links().size(), doc.c_str());
}

void SceneInstall::install_robot() {
  if (robot_.empty()) return;
  // A set of our own: the scene's obstacles (copied, meshes shared) and the robot's, so that
  // links added later never touch the set of the scene as loaded.
  auto set = std::make_shared<corde::ObstacleSet>();
  if (node_.world_.obstacles)
    for (int i = 0; i < node_.world_.obstacles->size(); ++i)
      set->add(node_.world_.obstacles->obstacle(i));
  robot_.install(set.get());
  node_.world_.obstacles = set;
}

}  // namespace corde_sim
