// SimNode: scenes, grasps and their inputs (pose, wrench and twist-rate topics, tf frames).
// Callbacks check a message and queue it as an InputEvent (command_queue.h); the loop applies it
// (apply_input) before its next batch of steps, as a time-stamped command of the simulation
// driver (corde::Simulation::submit), which takes effect at the start of the next step.
#include <ros/package.h>
#include <sys/stat.h>

#include <algorithm>
#include <cctype>
#include <cmath>

#include "corde_sim/ros/input_checks.h"
#include "corde_sim/ros/sim_node.h"

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

// First pose input of a grasp: the holder's reference glides there over this long instead of
// jumping (the holder limits shape the motion further).
constexpr double kFirstInputGlide = 0.1;  // s

}  // namespace

Eigen::Isometry3d to_eigen(const geometry_msgs::TransformStamped& t) {
  Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
  const auto& r = t.transform.rotation;
  out.linear() = Eigen::Quaterniond(r.w, r.x, r.y, r.z).normalized().toRotationMatrix();
  out.translation() << t.transform.translation.x, t.transform.translation.y,
      t.transform.translation.z;
  return out;
}

std::string SimNode::resolve_scene(const std::string& path, std::string* error) const {
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

std::string SimNode::install_scene(corde::Scene scene, const std::string& path) {
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
  for (const std::string& w : scene.warnings) ROS_WARN("corde_sim: scene: %s", w.c_str());
  for (const std::string& s : scene.settled) ROS_INFO("corde_sim: scene: %s", s.c_str());
  if (scene.mode == corde::Scene::Mode::kStatics)
    ROS_WARN(
        "corde_sim: scene: mode: statics is for corde_run; the node runs the scene (use "
        "initial_state: equilibrium to start it at rest in equilibrium)");
  for (const std::string& n : scene.notes) ROS_INFO("corde_sim: scene: %s", n.c_str());
  // Whether the guard had stopped the old world (the reply says that the new one resumes).
  guard_note_ = restart_guard();
  // Topics of grasps the new scene has too stay subscribed (a reset does not make publishers
  // reconnect); the others end.
  for (auto it = wiring_.begin(); it != wiring_.end();) {
    const bool kept = std::any_of(scene.grasps.begin(), scene.grasps.end(),
                                  [&](const corde::GraspSpec& g) { return g.name == it->first; });
    if (kept) it->second.scripted = false;  // add_grasp starts its script again
    it = kept ? std::next(it) : wiring_.erase(it);
  }
  sim_.install(scene.world);  // no grasps, scripts or commands; the holder limits stay
  install_robot();            // the robot's links join the new world's obstacles
  initial_ = std::move(scene);
  scene_path_ = path;
  settings_ = settings_from_world(world_);
  for (const corde::GraspSpec& spec : initial_.grasps) {
    auto p = params_.grasps.find(spec.name);
    const GraspSource source = p == params_.grasps.end() ? GraspSource::kTopic : p->second.source;
    const std::string frame = p == params_.grasps.end() ? "" : p->second.frame;
    int segment = -1;
    const std::string e = add_grasp(spec, source, frame, /*from_scene=*/true, &segment);
    if (!e.empty()) ROS_WARN("corde_sim: scene grasp not made: %s", e.c_str());
  }
  sim_.restart_guard();  // the grasps made are the state to go back to
  refresh_layout();
  return "";
}

std::string SimNode::add_grasp(const corde::GraspSpec& spec, GraspSource source,
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
  const corde::GraspState* held = grasps_.find(spec.name);
  if (held && held->held)
    return "grasp '" + spec.name + "' already holds rod '" + held->grasp.rod +
           "'; release it first";
  int rod = -1, seg = -1;
  std::string error = grasps_.check(world_, spec, &rod, &seg);
  if (!error.empty()) return "grasp '" + spec.name + "': " + error;

  GraspSourceParam param;
  auto p = params_.grasps.find(spec.name);
  if (p != params_.grasps.end()) param = p->second;
  // Without a frame to follow, the holder starts where the offset puts it relative to the segment
  // (the segment itself when no offset is given): nothing moves.
  const Eigen::Isometry3d segment_start = corde::segment_pose(world_.rods()[rod], seg);
  Eigen::Isometry3d holder = segment_start;
  if (param.has_offset) holder = holder * param.offset.inverse();
  const Eigen::Isometry3d* offset = nullptr;
  bool attached = true;
  if (source == GraspSource::kTf) {
    Eigen::Isometry3d f;
    if (lookup_world(frame, ros::Time(0), &f, &error)) {
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
  error = grasps_.add(world_, spec, holder, offset, world_.time());
  if (!error.empty()) return "grasp '" + spec.name + "': " + error;

  GraspWiring& w = wiring_[spec.name];
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
      sim_.add_script(spec, corde::ScriptDrive::kHolder);  // lets go until grasp_time
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
  wire_grasp(spec.name, &w);
  *segment = seg;
  return "";
}

bool SimNode::forget_grasp(const std::string& name) {
  const corde::GraspState* g = grasps_.find(name);
  if (!g || g->held || !g->force.isZero() || !g->torque.isZero()) return false;
  const auto& scene = initial_.grasps;
  if (std::any_of(scene.begin(), scene.end(),
                  [&](const corde::GraspSpec& s) { return s.name == name; }))
    return false;       // the scene's grasps stay listed (and subscribed) until a reset
  wiring_.erase(name);  // its subscriptions and reaction publisher end with it
  grasps_.erase(name);
  return true;
}

void SimNode::end_script(const std::string& name, const char* what) {
  auto w = wiring_.find(name);
  if (w == wiring_.end() || !w->second.scripted) return;
  w->second.scripted = false;
  sim_.end_script(name);  // the state to go back to, as the script has ended
  ROS_INFO(
      "corde_sim: grasp '%s' %s: its scene keyframes (and grasp or release time) no longer drive "
      "it (t = %.3f s)",
      name.c_str(), what, sim_time());
}

bool SimNode::waiting_to_take_hold(const std::string& name) const {
  return sim_.waiting_to_take_hold(name);
}

void SimNode::wire_grasp(const std::string& name, GraspWiring* w) {
  const std::string base = "grasps/" + name + "/";
  if (w->source != GraspSource::kTopic) {
    w->pose_sub.shutdown();
  } else if (!w->pose_sub) {
    w->pose_sub = nh_.subscribe<geometry_msgs::PoseStamped>(
        base + "pose", 10,
        boost::function<void(const geometry_msgs::PoseStampedConstPtr&)>(
            [this, name](const geometry_msgs::PoseStampedConstPtr& m) { on_pose(name, m); }));
  }
  if (!w->wrench_sub)
    w->wrench_sub = nh_.subscribe<geometry_msgs::WrenchStamped>(
        base + "wrench", 10,
        boost::function<void(const geometry_msgs::WrenchStampedConstPtr&)>(
            [this, name](const geometry_msgs::WrenchStampedConstPtr& m) { on_wrench(name, m); }));
  if (!w->twist_sub)
    w->twist_sub = nh_.subscribe<std_msgs::Float64>(
        base + "twist_rate", 10,
        boost::function<void(const std_msgs::Float64ConstPtr&)>(
            [this, name](const std_msgs::Float64ConstPtr& m) { on_twist_rate(name, m); }));
  if (!w->reaction_pub)
    w->reaction_pub = nh_.advertise<geometry_msgs::WrenchStamped>(base + "reaction", 10);
}

bool SimNode::own_frame(const std::string& frame, Eigen::Isometry3d* out) const {
  // The frames this node publishes itself never enter its tf buffer (it skips its own /tf).
  const std::string& prefix = params_.frame_prefix;
  if (frame.compare(0, prefix.size(), prefix) != 0) return false;
  const std::string rest = frame.substr(prefix.size());
  if (rest.compare(0, 6, "grasp/") == 0) {
    const corde::GraspState* g = grasps_.find(rest.substr(6));
    if (!g || !g->held) return false;
    *out = g->holder_pose();
    return true;
  }
  for (const corde::Rod& rod : world_.rods()) {
    const std::string& name = rod.name();
    if (rest.compare(0, name.size(), name) != 0) continue;
    const std::string sub = rest.substr(name.size());
    const int n = rod.num_segments();
    int node = -1, seg = -1;
    if (sub.empty()) {
      node = 0;
    } else if (sub == "/tip") {
      node = n;
    } else if (sub.compare(0, 5, "/seg_") == 0 && sub.size() > 5) {
      seg = std::atoi(sub.c_str() + 5);
      if (seg < 0 || seg >= n || std::to_string(seg) != sub.substr(5)) return false;
      *out = corde::segment_pose(rod, seg);
      return true;
    } else if (sub.compare(0, 6, "/node_") == 0 && sub.size() > 6) {
      node = std::atoi(sub.c_str() + 6);
      if (node < 0 || node > n || std::to_string(node) != sub.substr(6)) return false;
    } else {
      continue;
    }
    *out = Eigen::Isometry3d::Identity();
    out->linear() = rod.orientations()[std::min(node, n - 1)].normalized().toRotationMatrix();
    out->translation() = rod.positions()[node];
    return true;
  }
  return false;
}

bool SimNode::lookup_world(const std::string& frame, const ros::Time& stamp, Eigen::Isometry3d* out,
                           std::string* error) const {
  if (frame.empty()) {
    *error = "frame_id is empty: say which frame it is in (e.g. '" + params_.world_frame + "')";
    return false;
  }
  if (frame.size() > kMaxNameLength) {
    *error = "frame_id '" + clip(frame) + "' is longer than " + std::to_string(kMaxNameLength) +
             " characters";
    return false;
  }
  if (frame == params_.world_frame) {
    *out = Eigen::Isometry3d::Identity();
    return true;
  }
  if (own_frame(frame, out)) return true;
  const std::string& world = params_.world_frame;
  if (!tf_buffer_->_frameExists(frame)) {
    *error = "frame '" + clip(frame) + "' is unknown: no transform to or from it has been received";
    return false;
  }
  std::string why;
  if (!tf_buffer_->canTransform(world, frame, ros::Time(0), &why)) {
    *error = "frame '" + clip(frame) + "' is not connected to the world frame '" + world +
             "' in tf" +
             (tf_buffer_->_frameExists(world)
                  ? std::string(": ") + why
                  : " (nothing links any frame to '" + world +
                        "' yet; the rods' own frames are published by this node under it)");
    return false;
  }
  try {
    geometry_msgs::TransformStamped t;
    bool latest = stamp.isZero();
    if (!latest) {
      try {
        t = tf_buffer_->lookupTransform(world, frame, stamp);
      } catch (const tf2::ExtrapolationException&) {
        latest = true;
      }
    }
    if (latest) {
      t = tf_buffer_->lookupTransform(world, frame, ros::Time(0));
      // Static chains have stamp 0; a dynamic frame whose publisher stopped is not used.
      const double age = (ros::Time::now() - t.header.stamp).toSec();
      if (!t.header.stamp.isZero() && age > params_.max_frame_age) {
        *error = "frame '" + clip(frame) + "' was last published " + num(age) +
                 " s ago (~max_frame_age " + num(params_.max_frame_age) + " s)";
        return false;
      }
    }
    *out = to_eigen(t);
    return true;
  } catch (const tf2::TransformException& e) {
    *error = "frame '" + clip(frame) + "': " + e.what();
    return false;
  }
}

std::string SimNode::check_workspace(const Eigen::Vector3d& p) const {
  if ((p.array() >= params_.workspace_min.array()).all() &&
      (p.array() <= params_.workspace_max.array()).all())
    return "";
  const Eigen::Vector3d& a = params_.workspace_min;
  const Eigen::Vector3d& b = params_.workspace_max;
  return "position (" + num(p.x()) + ", " + num(p.y()) + ", " + num(p.z()) +
         ") in the world frame is outside the workspace [" + num(a.x()) + ", " + num(b.x()) +
         "] x [" + num(a.y()) + ", " + num(b.y()) + "] x [" + num(a.z()) + ", " + num(b.z()) +
         "] m (~workspace_min, ~workspace_max)";
}

double SimNode::ros_to_sim_interval(double ros_seconds) const {
  // Input stamps are ROS time: simulation time itself when this node publishes /clock, wall
  // time otherwise, which the simulation follows at the real-time factor.
  double d = ros_seconds;
  if (!params_.publish_clock) d *= pacer_.paced() ? pacer_.factor() : std::max(measured_rtf_, 1.0);
  return std::min(std::max(d, 0.0), params_.max_pose_age);
}

void SimNode::update_tf_holders() {
  for (auto& kv : wiring_) {
    GraspWiring& w = kv.second;
    const corde::GraspState* g = grasps_.find(kv.first);
    if (w.source != GraspSource::kTf || !g || !g->held) continue;
    Eigen::Isometry3d f;
    std::string error;
    if (!lookup_world(w.frame, ros::Time(0), &f, &error)) {
      // Holds where it is: a stale or vanished frame is not followed. (A scene grasp still waiting
      // for its frame said so when it was made.)
      if (w.attached)
        ROS_WARN_THROTTLE(2.0, "corde_sim: grasp '%s' holds still: %s", kv.first.c_str(),
                          error.c_str());
      continue;
    }
    geometry_msgs::TransformStamped t;
    double stamp = 0.0;
    try {
      stamp = tf_buffer_->lookupTransform(params_.world_frame, w.frame, ros::Time(0))
                  .header.stamp.toSec();
    } catch (const tf2::TransformException&) {
      stamp = ros::Time::now().toSec();  // one of our own frames: always current
    }
    if (stamp <= w.last_input_time) continue;  // nothing new
    if (!f.matrix().allFinite()) continue;
    error = check_workspace(f.translation());
    if (!error.empty()) {
      ROS_WARN_THROTTLE(2.0, "corde_sim: grasp '%s' holds still: frame '%s': %s", kv.first.c_str(),
                        w.frame.c_str(), error.c_str());
      continue;
    }
    InputEvent e;
    e.kind = InputEvent::Kind::kFrame;
    e.grasp = kv.first;
    e.pose = f;
    e.input_time = stamp;
    commands_.push_input(std::move(e));
  }
}

void SimNode::on_pose(const std::string& name, const geometry_msgs::PoseStampedConstPtr& msg) {
  const corde::GraspState* g = grasps_.find(name);
  if (waiting_to_take_hold(name)) {
    // Refused, the script kept: a publisher streaming poses from the start must not cancel the
    // grasp_time (the pose of an unheld grasp could not move anything anyway).
    ROS_WARN_THROTTLE(2.0,
                      "corde_sim: pose for grasp '%s' ignored: it takes hold at its grasp_time "
                      "t = %g s (now %.3f s); its poses are followed from then on",
                      name.c_str(), wiring_.at(name).script_spec.grasp_time, world_.time());
    return;
  }
  if (!g || !g->held) {
    ROS_WARN_THROTTLE(2.0, "corde_sim: pose for grasp '%s' ignored: it is released", name.c_str());
    return;
  }
  const ros::Time now = ros::Time::now();
  const bool zero = msg->header.stamp.isZero();
  std::string error =
      check_stamp_age((now - msg->header.stamp).toSec(), zero, params_.max_pose_age);
  Eigen::Vector3d p(msg->pose.position.x, msg->pose.position.y, msg->pose.position.z);
  Eigen::Quaterniond q(msg->pose.orientation.w, msg->pose.orientation.x, msg->pose.orientation.y,
                       msg->pose.orientation.z);
  if (error.empty()) error = check_pose(p, &q);
  Eigen::Isometry3d to_world;
  if (error.empty()) lookup_world(msg->header.frame_id, msg->header.stamp, &to_world, &error);
  InputEvent e;
  e.kind = InputEvent::Kind::kPose;
  e.grasp = name;
  if (error.empty()) {
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.linear() = q.toRotationMatrix();
    pose.translation() = p;
    e.pose = to_world * pose;
    error = check_workspace(e.pose.translation());
  }
  if (!error.empty()) {
    ROS_WARN_THROTTLE(1.0, "corde_sim: pose for grasp '%s' rejected: %s", name.c_str(),
                      error.c_str());
    return;
  }
  e.input_time = zero ? now.toSec() : msg->header.stamp.toSec();
  commands_.push_input(std::move(e));
}

void SimNode::on_wrench(const std::string& name, const geometry_msgs::WrenchStampedConstPtr& msg) {
  if (!grasps_.find(name)) return;
  const ros::Time now = ros::Time::now();
  std::string error = check_stamp_age((now - msg->header.stamp).toSec(), msg->header.stamp.isZero(),
                                      params_.max_pose_age);
  const Eigen::Vector3d f(msg->wrench.force.x, msg->wrench.force.y, msg->wrench.force.z);
  const Eigen::Vector3d tau(msg->wrench.torque.x, msg->wrench.torque.y, msg->wrench.torque.z);
  if (error.empty()) error = check_vector(f, "force");
  if (error.empty()) error = check_vector(tau, "torque");
  Eigen::Isometry3d to_world;
  if (error.empty()) lookup_world(msg->header.frame_id, msg->header.stamp, &to_world, &error);
  if (!error.empty()) {
    ROS_WARN_THROTTLE(1.0, "corde_sim: wrench for grasp '%s' rejected: %s", name.c_str(),
                      error.c_str());
    return;
  }
  InputEvent e;
  e.kind = InputEvent::Kind::kWrench;
  e.grasp = name;
  // Free vectors: only the rotation applies.
  e.force = to_world.linear() * f;
  e.torque = to_world.linear() * tau;
  commands_.push_input(std::move(e));
}

void SimNode::on_twist_rate(const std::string& name, const std_msgs::Float64ConstPtr& msg) {
  const corde::GraspState* g = grasps_.find(name);
  std::string error;
  if (!g || !g->held)
    error = "the grasp is released";
  else if (!std::isfinite(msg->data) || std::abs(msg->data) > 1e4)
    error = "rate must be finite and at most 1e4 rad/s";
  else if (!g->grasp.hold_orientation)
    error = "the grasp does not hold the segment's orientation";
  if (!error.empty()) {
    ROS_WARN_THROTTLE(1.0, "corde_sim: twist_rate for grasp '%s' rejected: %s", name.c_str(),
                      error.c_str());
    return;
  }
  InputEvent e;
  e.kind = InputEvent::Kind::kTwistRate;
  e.grasp = name;
  e.rate = msg->data;
  commands_.push_input(std::move(e));
}

void SimNode::apply_input(const InputEvent& e) {
  auto w = wiring_.find(e.grasp);
  if (w == wiring_.end()) return;  // the scene was replaced since
  switch (e.kind) {
    case InputEvent::Kind::kPose: {
      const corde::GraspState* g = grasps_.find(e.grasp);
      if (!g || !g->held) {
        // Let go since the pose was queued: it would move nothing, and must not end a script
        // that still takes hold later.
        ROS_WARN_THROTTLE(2.0, "corde_sim: pose for grasp '%s' ignored: it is not held",
                          e.grasp.c_str());
        break;
      }
      double& last = w->second.last_input_time;
      if (last >= 0.0 && e.input_time < last) {
        ROS_WARN_THROTTLE(1.0,
                          "corde_sim: pose for grasp '%s' rejected: stamp older than the "
                          "previous pose",
                          e.grasp.c_str());
        break;
      }
      const double interval =
          last < 0.0 ? kFirstInputGlide : ros_to_sim_interval(e.input_time - last);
      last = e.input_time;
      if (w->second.scripted) end_script(e.grasp, "follows its pose input from now on");
      sim_.submit(corde::Command::goal(world_.time(), e.grasp, e.pose, interval));
      break;
    }
    case InputEvent::Kind::kFrame: {
      GraspWiring& wr = w->second;
      const corde::GraspState* g = grasps_.find(e.grasp);
      if (wr.source != GraspSource::kTf || !g || !g->held || e.input_time <= wr.last_input_time)
        break;
      if (wr.scripted)
        end_script(e.grasp, ("follows tf frame '" + wr.frame + "' from now on").c_str());
      if (!wr.attached) {
        grasps_.attach(world_, e.grasp, e.pose, wr.snap ? &wr.offset : nullptr, world_.time());
        sim_.mark_good();  // a rollback goes back to the attached grasp, not before it
        wr.attached = true;
        ROS_INFO("corde_sim: grasp '%s' now follows frame '%s'", e.grasp.c_str(), wr.frame.c_str());
      } else {
        const double interval = wr.last_input_time < 0.0 ? 0.0 : e.input_time - wr.last_input_time;
        sim_.submit(
            corde::Command::goal(world_.time(), e.grasp, e.pose, ros_to_sim_interval(interval)));
      }
      wr.last_input_time = e.input_time;
      break;
    }
    case InputEvent::Kind::kWrench:
      sim_.submit(corde::Command::wrench(world_.time(), e.grasp, e.force, e.torque));
      break;
    case InputEvent::Kind::kTwistRate:
      sim_.submit(corde::Command::twist_rate(world_.time(), e.grasp, e.rate));
      break;
  }
}

void SimNode::check_holders_and_strain() {
  for (const auto& kv : grasps_.grasps()) {
    const corde::GraspState& g = kv.second;
    if (!g.clip.any()) continue;
    ROS_WARN_THROTTLE(2.0,
                      "corde_sim: grasp '%s': holder motion limited to %s (it lags its commanded "
                      "pose; ~holder_max_speed %g m/s, ~holder_max_acceleration %g m/s^2)",
                      kv.first.c_str(), g.clip.speed ? "the speed limit" : "the acceleration limit",
                      params_.holder_max_speed, params_.holder_max_acceleration);
    grasps_.find(kv.first)->clip = corde::HolderClip();
  }
  // strain_warning_ stays until the next diagnostics report (diagnose() clears it), so that a short
  // overstretch (which may end with a slip) is still reported.
  for (size_t r = 0; r < world_.rods().size(); ++r) {
    const corde::Rod& rod = world_.rods()[r];
    const double limit = rod.section().max_strain;
    if (!(limit > 0.0)) continue;
    int seg = 0;
    const double strain = rod.max_stretch_strain(&seg);
    if (strain <= limit) continue;
    strain_warning_ = "rod '" + rod.name() + "' stretched by " + num(100.0 * strain) +
                      "% at segment " + std::to_string(seg) + ", above its material's max_strain " +
                      num(100.0 * limit) + "% (length " + num(rod.length()) + " m)";
    ROS_WARN_THROTTLE(2.0, "corde_sim: %s", strain_warning_.c_str());
    if (params_.strain_action != StrainAction::kSlip) continue;
    // The holder nearest to the overstretched segment lets go, as a real grip slips first there.
    std::string nearest;
    int best = 1 << 30;
    for (const auto& kv : grasps_.grasps())
      if (kv.second.held && kv.second.rod == static_cast<int>(r) &&
          std::abs(kv.second.grasp.segment - seg) < best) {
        best = std::abs(kv.second.grasp.segment - seg);
        nearest = kv.first;
      }
    if (!nearest.empty()) {
      sim_.submit(corde::Command::release(world_.time(), nearest));
      sim_.apply_due();
      end_script(nearest, "slipped");
      // As a release by service: a rollback must not hold the segment again (grasps_ goes back
      // with the world), the node having said that it slipped.
      sim_.mark_good();
      ROS_WARN("corde_sim: grasp '%s' slipped (~strain_action slip): %s", nearest.c_str(),
               strain_warning_.c_str());
      refresh_layout();
    }
  }
}

void SimNode::publish_reactions() {
  for (auto& kv : wiring_) {
    Eigen::Vector3d f, tau;
    if (!grasps_.take_reaction(kv.first, &f, &tau)) continue;
    if (!kv.second.reaction_pub || kv.second.reaction_pub.getNumSubscribers() == 0) continue;
    if (!f.allFinite() || !tau.allFinite()) continue;  // never leaves the node
    geometry_msgs::WrenchStamped m;
    m.header.stamp = stamp();
    m.header.frame_id = params_.frame_prefix + "grasp/" + kv.first;
    m.wrench.force.x = f.x();
    m.wrench.force.y = f.y();
    m.wrench.force.z = f.z();
    m.wrench.torque.x = tau.x();
    m.wrench.torque.y = tau.y();
    m.wrench.torque.z = tau.z();
    kv.second.reaction_pub.publish(m);
  }
}

}  // namespace corde_sim
