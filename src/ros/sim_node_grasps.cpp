// SimNode: scenes, grasps and their inputs (pose, wrench and twist-rate topics, tf frames).
#include <algorithm>
#include <cctype>
#include <cmath>

#include "corde_sim/ros/input_checks.h"
#include "corde_sim/ros/sim_node.h"

namespace corde_sim {
namespace {

// Valid as a graph name component, so that grasps/<name>/pose is a legal topic.
bool valid_name(const std::string& s) {
  if (s.empty() || !std::isalpha(static_cast<unsigned char>(s[0]))) return false;
  return std::all_of(s.begin(), s.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_';
  });
}

// Material coordinate (rest arc length) of a segment's midpoint.
double segment_arc_length(const corde::Rod& rod, int segment) {
  double s = 0.0;
  for (int i = 0; i < segment; ++i) s += rod.rest_lengths()[i];
  return s + 0.5 * rod.rest_lengths()[segment];
}

Eigen::Isometry3d to_eigen(const geometry_msgs::TransformStamped& t) {
  Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
  const auto& r = t.transform.rotation;
  out.linear() = Eigen::Quaterniond(r.w, r.x, r.y, r.z).normalized().toRotationMatrix();
  out.translation() << t.transform.translation.x, t.transform.translation.y,
      t.transform.translation.z;
  return out;
}

// First pose input of a grasp: the holder glides there over this long instead of jumping.
constexpr double kFirstInputGlide = 0.1;  // s

}  // namespace

std::string SimNode::install_scene(corde::Scene scene, const std::string& path) {
  // Check every grasp before anything changes, so that a bad scene leaves the node as it was.
  for (const corde::GraspSpec& spec : scene.grasps) {
    try {
      corde::grasp_segment(scene.world.rod(spec.rod), spec);
    } catch (const std::exception& e) {
      return "grasp '" + spec.name + "': " + e.what();
    }
    if (!valid_name(spec.name))
      return "grasp name '" + spec.name + "' is not a valid ROS name ([A-Za-z][A-Za-z0-9_]*)";
  }
  for (const std::string& w : scene.warnings) ROS_WARN("corde_sim: scene: %s", w.c_str());
  grasps_.clear();  // also ends their subscriptions
  world_ = scene.world;
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
  last_good_ = world_;
  refresh_layout();
  return "";
}

std::string SimNode::add_grasp(const corde::GraspSpec& spec, GraspSource source,
                               const std::string& frame, bool from_scene, int* segment) {
  *segment = -1;
  if (!valid_name(spec.name))
    return "grasp name '" + spec.name + "' is not a valid ROS name ([A-Za-z][A-Za-z0-9_]*)";
  auto existing = grasps_.find(spec.name);
  if (existing != grasps_.end() && existing->second.held)
    return "grasp '" + spec.name + "' already holds rod '" + existing->second.grasp.rod +
           "'; release it first";
  int rod_index = -1;
  for (size_t i = 0; i < world_.rods().size(); ++i)
    if (world_.rods()[i].name() == spec.rod) rod_index = static_cast<int>(i);
  if (rod_index < 0) return "no rod named '" + spec.rod + "'";
  corde::Rod& rod = world_.rods()[rod_index];
  int seg;
  try {
    seg = corde::grasp_segment(rod, spec);
  } catch (const std::exception& e) {
    return "grasp '" + spec.name + "': " + e.what();
  }
  // A boundary condition (clamp, fixed or driven node or segment) there would be replaced by the
  // grasp's drives and lost on release. Grasp drives are the kTarget ones.
  for (int node : {seg, seg + 1}) {
    const corde::NodeDrive* d = rod.node_drive(node);
    if (d && d->kind != corde::NodeDrive::Kind::kTarget)
      return "grasp '" + spec.name + "': node " + std::to_string(node) + " of segment " +
             std::to_string(seg) + " has a boundary condition";
  }
  const corde::SegmentDrive* sd = rod.segment_drive(seg);
  if (spec.hold_orientation && sd && sd->kind != corde::SegmentDrive::Kind::kTarget)
    return "grasp '" + spec.name + "': segment " + std::to_string(seg) +
           " has a boundary condition";
  if (source == GraspSource::kTf && frame.empty())
    return "grasp '" + spec.name + "': source tf needs a frame";

  Eigen::Isometry3d holder = corde::segment_pose(rod, seg);
  bool attached = true;
  if (source == GraspSource::kTf) {
    Eigen::Isometry3d f;
    std::string error;
    if (lookup_world(frame, ros::Time(0), &f, &error)) {
      holder = f;
    } else if (from_scene) {
      // The frame may not be published yet: hold the segment where it is until it appears.
      attached = false;
      ROS_WARN(
          "corde_sim: grasp '%s' follows tf frame '%s', not available yet (%s); holding "
          "the segment in place until it is",
          spec.name.c_str(), frame.c_str(), error.c_str());
    } else {
      return "grasp '" + spec.name + "': unknown frame '" + frame + "': " + error;
    }
  }

  ActiveGrasp& g = grasps_[spec.name];
  const bool reuse = existing != grasps_.end();
  g.spec = spec;
  g.grasp = corde::make_grasp(rod, spec, holder);
  g.source = source;
  g.frame = frame;
  g.held = true;
  g.attached = attached;
  g.rod_index = rod_index;
  g.holder.reset(holder);
  g.last_input_time = -1.0;
  g.twist_rate = g.twist_angle = 0.0;
  g.arc_length = segment_arc_length(rod, g.grasp.segment);
  if (!reuse) {
    g.marker_id = next_marker_id_++;
    const std::string base = "grasps/" + spec.name + "/";
    const std::string name = spec.name;
    if (source == GraspSource::kTopic)
      g.pose_sub = nh_.subscribe<geometry_msgs::PoseStamped>(
          base + "pose", 10,
          boost::function<void(const geometry_msgs::PoseStampedConstPtr&)>(
              [this, name](const geometry_msgs::PoseStampedConstPtr& m) { on_pose(name, m); }));
    g.wrench_sub = nh_.subscribe<geometry_msgs::WrenchStamped>(
        base + "wrench", 10,
        boost::function<void(const geometry_msgs::WrenchStampedConstPtr&)>(
            [this, name](const geometry_msgs::WrenchStampedConstPtr& m) { on_wrench(name, m); }));
    g.twist_sub = nh_.subscribe<std_msgs::Float64>(
        base + "twist_rate", 10,
        boost::function<void(const std_msgs::Float64ConstPtr&)>(
            [this, name](const std_msgs::Float64ConstPtr& m) { on_twist_rate(name, m); }));
  } else if (source != GraspSource::kTopic) {
    g.pose_sub.shutdown();
  } else if (!g.pose_sub) {
    const std::string name = spec.name;
    g.pose_sub = nh_.subscribe<geometry_msgs::PoseStamped>(
        "grasps/" + name + "/pose", 10,
        boost::function<void(const geometry_msgs::PoseStampedConstPtr&)>(
            [this, name](const geometry_msgs::PoseStampedConstPtr& m) { on_pose(name, m); }));
  }
  if (!reuse || g.load_index < 0) {
    g.load_index = static_cast<int>(rod.loads().size());
    for (int k = 0; k < 3; ++k) {
      corde::Load load;
      load.kind = k < 2 ? corde::Load::Kind::kForce : corde::Load::Kind::kTorque;
      rod.add_load(load);
    }
  }
  set_wrench_loads(&g);
  *segment = g.grasp.segment;
  return "";
}

void SimNode::set_wrench_loads(ActiveGrasp* g) {
  // The force acts at the grasp point (the segment's midpoint): half on each of its nodes.
  corde::Rod& rod = world_.rods()[g->rod_index];
  if (g->load_index < 0 || g->load_index + 2 >= static_cast<int>(rod.loads().size())) return;
  const int s = g->grasp.segment;
  corde::Load* l = &rod.loads()[g->load_index];
  l[0].index = s;
  l[0].value = 0.5 * g->force;
  l[1].index = s + 1;
  l[1].value = 0.5 * g->force;
  l[2].index = s;
  l[2].value = g->torque;
}

void SimNode::remake_grasps_on(const std::string& rod_name) {
  // After a resample the segment indices changed: grasp again at the same material coordinate,
  // holding the holder where it is (make_grasp records the new offset, so nothing jumps).
  for (auto& kv : grasps_) {
    ActiveGrasp& g = kv.second;
    if (g.grasp.rod != rod_name) continue;
    corde::Rod& rod = world_.rods()[g.rod_index];
    if (g.held) {
      const Eigen::Isometry3d holder = holder_pose(g, sim_time());
      g.spec.place = corde::GraspSpec::Place::kArcLength;
      g.spec.value = g.arc_length;
      g.grasp = corde::make_grasp(rod, g.spec, holder);
      g.holder.reset(holder);
      g.twist_angle = 0.0;
      corde::hold(rod, g.grasp, holder);
    } else {
      corde::GraspSpec spec = g.spec;
      spec.place = corde::GraspSpec::Place::kArcLength;
      spec.value = g.arc_length;
      g.grasp.segment = corde::grasp_segment(rod, spec);
    }
    set_wrench_loads(&g);
  }
}

Eigen::Isometry3d SimNode::holder_pose(const ActiveGrasp& g, double t) const {
  Eigen::Isometry3d h = g.holder.at(t);
  if (g.twist_angle != 0.0) {
    // Turn the held segment about its own tangent (d3): holder * offset * Rz * offset^-1.
    const Eigen::Isometry3d spin(Eigen::AngleAxisd(g.twist_angle, Eigen::Vector3d::UnitZ()));
    h = h * g.grasp.offset * spin * g.grasp.offset.inverse();
  }
  return h;
}

void SimNode::hold_all(double t_end, double h) {
  for (auto& kv : grasps_) {
    ActiveGrasp& g = kv.second;
    if (!g.held) continue;
    if (g.twist_rate != 0.0)
      g.twist_angle = std::remainder(g.twist_angle + g.twist_rate * h, 2.0 * M_PI);
    corde::hold(world_.rods()[g.rod_index], g.grasp, holder_pose(g, t_end));
  }
}

bool SimNode::lookup_world(const std::string& frame, const ros::Time& stamp, Eigen::Isometry3d* out,
                           std::string* error) const {
  if (frame.empty() || frame == params_.world_frame) {
    *out = Eigen::Isometry3d::Identity();
    return true;
  }
  try {
    geometry_msgs::TransformStamped t;
    try {
      t = tf_buffer_->lookupTransform(params_.world_frame, frame, stamp);
    } catch (const tf2::ExtrapolationException&) {
      t = tf_buffer_->lookupTransform(params_.world_frame, frame, ros::Time(0));
    }
    *out = to_eigen(t);
    return true;
  } catch (const tf2::TransformException& e) {
    *error = e.what();
    return false;
  }
}

void SimNode::on_tf(const ros::MessageEvent<tf2_msgs::TFMessage const>& ev, bool is_static) {
  if (ev.getPublisherName() == ros::this_node::getName()) return;  // our own rods
  const std::string authority = ev.getPublisherName();
  for (const geometry_msgs::TransformStamped& t : ev.getMessage()->transforms) {
    try {
      tf_buffer_->setTransform(t, authority, is_static);
    } catch (const std::exception& e) {
      ROS_WARN_THROTTLE(5.0, "corde_sim: ignoring a transform from %s: %s", authority.c_str(),
                        e.what());
    }
  }
}

double SimNode::ros_to_sim_interval(double ros_seconds) const {
  // Input stamps are ROS time: simulation time itself when this node publishes /clock, wall
  // time otherwise, which the simulation follows at the real-time factor.
  double d = ros_seconds;
  if (!params_.publish_clock) d *= pacer_.paced() ? pacer_.factor() : std::max(measured_rtf_, 1.0);
  return std::min(std::max(d, 0.0), params_.max_pose_age);
}

void SimNode::update_tf_holders() {
  for (auto& kv : grasps_) {
    ActiveGrasp& g = kv.second;
    if (!g.held || g.source != GraspSource::kTf) continue;
    geometry_msgs::TransformStamped t;
    try {
      t = tf_buffer_->lookupTransform(params_.world_frame, g.frame, ros::Time(0));
    } catch (const tf2::TransformException& e) {
      ROS_WARN_THROTTLE(2.0, "corde_sim: grasp '%s' cannot follow frame '%s': %s", kv.first.c_str(),
                        g.frame.c_str(), e.what());
      continue;
    }
    const double stamp = t.header.stamp.toSec();
    if (stamp <= g.last_input_time) continue;  // nothing new
    const Eigen::Isometry3d f = to_eigen(t);
    if (!f.matrix().allFinite()) continue;
    corde::Rod& rod = world_.rods()[g.rod_index];
    if (!g.attached) {
      corde::release(rod, g.grasp);
      g.grasp = corde::make_grasp(rod, g.spec, f);
      g.holder.reset(f);
      g.attached = true;
      ROS_INFO("corde_sim: grasp '%s' now follows frame '%s'", kv.first.c_str(), g.frame.c_str());
    } else {
      const double interval = g.last_input_time < 0.0 ? 0.0 : stamp - g.last_input_time;
      g.holder.set_goal(sim_time(), f, ros_to_sim_interval(interval));
    }
    g.last_input_time = stamp;
  }
}

void SimNode::on_pose(const std::string& name, const geometry_msgs::PoseStampedConstPtr& msg) {
  auto it = grasps_.find(name);
  if (it == grasps_.end() || !it->second.held) {
    ROS_WARN_THROTTLE(2.0, "corde_sim: pose for grasp '%s' ignored: it is released", name.c_str());
    return;
  }
  ActiveGrasp& g = it->second;
  const ros::Time now = ros::Time::now();
  const bool zero = msg->header.stamp.isZero();
  std::string error =
      check_stamp_age((now - msg->header.stamp).toSec(), zero, params_.max_pose_age);
  Eigen::Vector3d p(msg->pose.position.x, msg->pose.position.y, msg->pose.position.z);
  Eigen::Quaterniond q(msg->pose.orientation.w, msg->pose.orientation.x, msg->pose.orientation.y,
                       msg->pose.orientation.z);
  if (error.empty()) error = check_pose(p, &q);
  Eigen::Isometry3d to_world;
  if (error.empty() && !lookup_world(msg->header.frame_id, msg->header.stamp, &to_world, &error))
    error = "unknown frame '" + msg->header.frame_id + "': " + error;
  const double t_in = zero ? now.toSec() : msg->header.stamp.toSec();
  if (error.empty() && g.last_input_time >= 0.0 && t_in < g.last_input_time)
    error = "stamp older than the previous pose";
  if (!error.empty()) {
    ROS_WARN_THROTTLE(1.0, "corde_sim: pose for grasp '%s' rejected: %s", name.c_str(),
                      error.c_str());
    return;
  }
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = q.toRotationMatrix();
  pose.translation() = p;
  const double interval =
      g.last_input_time < 0.0 ? kFirstInputGlide : ros_to_sim_interval(t_in - g.last_input_time);
  g.last_input_time = t_in;
  g.holder.set_goal(sim_time(), to_world * pose, interval);
}

void SimNode::on_wrench(const std::string& name, const geometry_msgs::WrenchStampedConstPtr& msg) {
  auto it = grasps_.find(name);
  if (it == grasps_.end()) return;
  ActiveGrasp& g = it->second;
  const ros::Time now = ros::Time::now();
  std::string error = check_stamp_age((now - msg->header.stamp).toSec(), msg->header.stamp.isZero(),
                                      params_.max_pose_age);
  const Eigen::Vector3d f(msg->wrench.force.x, msg->wrench.force.y, msg->wrench.force.z);
  const Eigen::Vector3d tau(msg->wrench.torque.x, msg->wrench.torque.y, msg->wrench.torque.z);
  if (error.empty()) error = check_vector(f, "force");
  if (error.empty()) error = check_vector(tau, "torque");
  Eigen::Isometry3d to_world;
  if (error.empty() && !lookup_world(msg->header.frame_id, msg->header.stamp, &to_world, &error))
    error = "unknown frame '" + msg->header.frame_id + "': " + error;
  if (!error.empty()) {
    ROS_WARN_THROTTLE(1.0, "corde_sim: wrench for grasp '%s' rejected: %s", name.c_str(),
                      error.c_str());
    return;
  }
  // Free vectors: only the rotation applies.
  g.force = to_world.linear() * f;
  g.torque = to_world.linear() * tau;
  set_wrench_loads(&g);
}

void SimNode::on_twist_rate(const std::string& name, const std_msgs::Float64ConstPtr& msg) {
  auto it = grasps_.find(name);
  std::string error;
  if (it == grasps_.end() || !it->second.held)
    error = "the grasp is released";
  else if (!std::isfinite(msg->data) || std::abs(msg->data) > 1e4)
    error = "rate must be finite and at most 1e4 rad/s";
  else if (!it->second.grasp.hold_orientation)
    error = "the grasp does not hold the segment's orientation";
  if (!error.empty()) {
    ROS_WARN_THROTTLE(1.0, "corde_sim: twist_rate for grasp '%s' rejected: %s", name.c_str(),
                      error.c_str());
    return;
  }
  it->second.twist_rate = msg->data;
}

}  // namespace corde_sim
