// NodeInputs: the grasps' topics (pose, wrench, twist rate), tf frames (grasps following a frame,
// the robot's links) and dynamic_reconfigure. Callbacks check a message and queue it as an
// InputEvent (command_queue.h); the loop applies it (apply_input) before its next batch of steps,
// as a time-stamped command of the simulation driver (corde::Simulation::submit), which takes
// effect at the start of the next step.
#include "corde_sim/ros/node_inputs.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "corde_sim/grasp/pose_timeline.h"
#include "corde_sim/ros/grip_input.h"
#include "corde_sim/ros/input_checks.h"
#include "corde_sim/ros/sim_node.h"

namespace corde_sim {
namespace {

// First pose input of a grasp: the holder's reference glides there over this long instead of
// jumping (the holder limits shape the motion further).
constexpr double kFirstInputGlide = 0.1;  // s

// A stamped pose this far (s) ahead of the simulation's time does not belong to its clock: it is
// followed as it arrives, as an unstamped one.
constexpr double kMaxStampLead = 1.0;

// s of simulation time a link's glide may run behind its tf poses beyond one interval: covers
// the jitter with which poses arrive and are picked up (up to about 20 ms measured with a
// loaded 2-core machine and tf at 100 Hz), so that jitter does not change the link's speed,
// while a simulation slower than real time still follows the robot closely.
constexpr double kRobotMaxGlideLag = 0.05;

}  // namespace

Eigen::Isometry3d to_eigen(const geometry_msgs::TransformStamped& t) {
  Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
  const auto& r = t.transform.rotation;
  out.linear() = Eigen::Quaterniond(r.w, r.x, r.y, r.z).normalized().toRotationMatrix();
  out.translation() << t.transform.translation.x, t.transform.translation.y,
      t.transform.translation.z;
  return out;
}

geometry_msgs::Pose to_pose_msg(const Eigen::Isometry3d& pose) {
  geometry_msgs::Pose p;
  const Eigen::Quaterniond q(pose.linear());
  p.position.x = pose.translation().x();
  p.position.y = pose.translation().y();
  p.position.z = pose.translation().z();
  p.orientation.x = q.x();
  p.orientation.y = q.y();
  p.orientation.z = q.z();
  p.orientation.w = q.w();
  return p;
}

void NodeInputs::start_tf() {
  // Own subscriptions so that this node's own (large) /tf messages are skipped without being
  // stored; everything else goes into the buffer.
  tf_buffer_ = std::make_unique<tf2_ros::Buffer>();
  tf_input_ = std::make_unique<TfInput>(node_.nh_, tf_buffer_.get());
}

void NodeInputs::start_reconfigure() {
  const NodeParams& params = node_.params_;
  NodeConfig initial;
  initial.real_time_factor = params.real_time_factor;
  initial.tf_rate = params.tf_rate;
  initial.marker_rate = params.marker_rate;
  initial.state_rate = params.state_rate;
  initial.marker_style =
      params.marker_style == MarkerStyle::kLineStrip ? "line_strip" : "cylinders";
  initial.marker_min_diameter = params.marker_min_diameter;
  initial.holder_max_speed = params.holder_max_speed;
  initial.holder_max_acceleration = params.holder_max_acceleration;
  reconfigure_ = std::make_unique<ReconfigureInput>(
      node_.pnh_, initial, &node_.commands_, &node_.loop_running_,
      [this](const NodeConfig& c) { apply_reconfigure(c); });
}

void NodeInputs::wire_grasp(const std::string& name, GraspWiring* w) {
  const std::string base = "grasps/" + name + "/";
  if (w->source != GraspSource::kTopic) {
    w->pose_sub.shutdown();
  } else if (!w->pose_sub) {
    w->pose_sub = node_.nh_.subscribe<geometry_msgs::PoseStamped>(
        base + "pose", 10,
        boost::function<void(const geometry_msgs::PoseStampedConstPtr&)>(
            [this, name](const geometry_msgs::PoseStampedConstPtr& m) { on_pose(name, m); }));
  }
  if (!w->wrench_sub)
    w->wrench_sub = node_.nh_.subscribe<geometry_msgs::WrenchStamped>(
        base + "wrench", 10,
        boost::function<void(const geometry_msgs::WrenchStampedConstPtr&)>(
            [this, name](const geometry_msgs::WrenchStampedConstPtr& m) { on_wrench(name, m); }));
  if (!w->twist_sub)
    w->twist_sub = node_.nh_.subscribe<std_msgs::Float64>(
        base + "twist_rate", 10,
        boost::function<void(const std_msgs::Float64ConstPtr&)>(
            [this, name](const std_msgs::Float64ConstPtr& m) { on_twist_rate(name, m); }));
  if (!w->reaction_pub)
    w->reaction_pub = node_.nh_.advertise<geometry_msgs::WrenchStamped>(base + "reaction", 10);
  if (!w->grip_sub)
    w->grip_sub = node_.nh_.subscribe<std_msgs::Float64>(
        base + "grip", 10,
        boost::function<void(const std_msgs::Float64ConstPtr&)>(
            [this, name](const std_msgs::Float64ConstPtr& m) { on_grip(name, m); }));
  const corde::GraspState* g = node_.grasps_.find(name);
  if (!w->slip_pub && g && g->spec.grip.friction)
    w->slip_pub = node_.nh_.advertise<std_msgs::Float64>(base + "slip", 10);
}

bool NodeInputs::own_frame(const std::string& frame, Eigen::Isometry3d* out) const {
  // The frames this node publishes itself never enter its tf buffer (it skips its own /tf).
  const std::string& prefix = node_.params_.frame_prefix;
  if (frame.compare(0, prefix.size(), prefix) != 0) return false;
  const std::string rest = frame.substr(prefix.size());
  if (rest.compare(0, 6, "grasp/") == 0) {
    const corde::GraspState* g = node_.grasps_.find(rest.substr(6));
    if (!g || !g->held) return false;
    *out = g->holder_pose();
    return true;
  }
  for (const corde::Rod& rod : node_.world_.rods()) {
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

bool NodeInputs::lookup_world(const std::string& frame, const ros::Time& stamp,
                              Eigen::Isometry3d* out, std::string* error) const {
  if (frame.empty()) {
    *error =
        "frame_id is empty: say which frame it is in (e.g. '" + node_.params_.world_frame + "')";
    return false;
  }
  if (frame.size() > kMaxNameLength) {
    *error = "frame_id '" + clip(frame) + "' is longer than " + std::to_string(kMaxNameLength) +
             " characters";
    return false;
  }
  if (frame == node_.params_.world_frame) {
    *out = Eigen::Isometry3d::Identity();
    return true;
  }
  if (own_frame(frame, out)) return true;
  const std::string& world = node_.params_.world_frame;
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
      if (!t.header.stamp.isZero() && age > node_.params_.max_frame_age) {
        *error = "frame '" + clip(frame) + "' was last published " + num(age) +
                 " s ago (~max_frame_age " + num(node_.params_.max_frame_age) + " s)";
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

std::string NodeInputs::check_workspace(const Eigen::Vector3d& p) const {
  if ((p.array() >= node_.params_.workspace_min.array()).all() &&
      (p.array() <= node_.params_.workspace_max.array()).all())
    return "";
  const Eigen::Vector3d& a = node_.params_.workspace_min;
  const Eigen::Vector3d& b = node_.params_.workspace_max;
  return "position (" + num(p.x()) + ", " + num(p.y()) + ", " + num(p.z()) +
         ") in the world frame is outside the workspace [" + num(a.x()) + ", " + num(b.x()) +
         "] x [" + num(a.y()) + ", " + num(b.y()) + "] x [" + num(a.z()) + ", " + num(b.z()) +
         "] m (~workspace_min, ~workspace_max)";
}

double NodeInputs::ros_to_sim_interval(double ros_seconds) const {
  // Input stamps are ROS time; the time model says how much simulation time it stands for.
  const double d = node_.clock_.sim_interval(ros_seconds);
  return std::min(std::max(d, 0.0), node_.params_.max_pose_age);
}

double NodeInputs::sim_time_of_stamp(double ros_stamp) const {
  // The inverse of the outputs' stamps (SimNode::stamp()): the one time model.
  return node_.clock().sim_time_at(ros_stamp);
}

void NodeInputs::update_tf_holders() {
  for (auto& kv : node_.wiring_) {
    GraspWiring& w = kv.second;
    const corde::GraspState* g = node_.grasps_.find(kv.first);
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
      stamp = tf_buffer_->lookupTransform(node_.params_.world_frame, w.frame, ros::Time(0))
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
    node_.commands_.push_input(std::move(e));
  }
}

void NodeInputs::on_pose(const std::string& name, const geometry_msgs::PoseStampedConstPtr& msg) {
  const corde::GraspState* g = node_.grasps_.find(name);
  if (node_.scene_.waiting_to_take_hold(name)) {
    // Refused, the script kept: a publisher streaming poses from the start must not cancel the
    // grasp_time (the pose of an unheld grasp could not move anything anyway).
    ROS_WARN_THROTTLE(2.0,
                      "corde_sim: pose for grasp '%s' ignored: it takes hold at its grasp_time "
                      "t = %g s (now %.3f s); its poses are followed from then on",
                      name.c_str(), node_.wiring_.at(name).script_spec.grasp_time,
                      node_.world_.time());
    return;
  }
  if (!g || !g->held) {
    ROS_WARN_THROTTLE(2.0, "corde_sim: pose for grasp '%s' ignored: it is released", name.c_str());
    return;
  }
  const ros::Time now = ros::Time::now();
  const bool zero = msg->header.stamp.isZero();
  std::string error =
      check_stamp_age((now - msg->header.stamp).toSec(), zero, node_.params_.max_pose_age);
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
  e.stamped = !zero;
  node_.commands_.push_input(std::move(e));
}

void NodeInputs::on_wrench(const std::string& name,
                           const geometry_msgs::WrenchStampedConstPtr& msg) {
  if (!node_.grasps_.find(name)) return;
  const ros::Time now = ros::Time::now();
  std::string error = check_stamp_age((now - msg->header.stamp).toSec(), msg->header.stamp.isZero(),
                                      node_.params_.max_pose_age);
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
  node_.commands_.push_input(std::move(e));
}

void NodeInputs::on_twist_rate(const std::string& name, const std_msgs::Float64ConstPtr& msg) {
  const corde::GraspState* g = node_.grasps_.find(name);
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
  node_.commands_.push_input(std::move(e));
}

void NodeInputs::on_grip(const std::string& name, const std_msgs::Float64ConstPtr& msg) {
  const std::string error = check_grip(node_.grasps_, name, msg->data);
  if (!error.empty()) {
    ROS_WARN_THROTTLE(1.0, "corde_sim: grip for grasp '%s' rejected: %s", name.c_str(),
                      error.c_str());
    return;
  }
  InputEvent e;
  e.kind = InputEvent::Kind::kGrip;
  e.grasp = name;
  e.grip_force = msg->data;
  node_.commands_.push_input(std::move(e));
}

void NodeInputs::apply_input(const InputEvent& e) {
  auto w = node_.wiring_.find(e.grasp);
  if (w == node_.wiring_.end()) return;  // the scene was replaced since
  switch (e.kind) {
    case InputEvent::Kind::kPose: {
      const corde::GraspState* g = node_.grasps_.find(e.grasp);
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
      if (w->second.scripted)
        node_.scene_.end_script(e.grasp, "follows its pose input from now on");
      const double now = node_.world_.time();
      // A stamped pose is followed at its stamp (world time), interpolated between the poses
      // of its stream; one whose stamp is not near the simulation's time, or an unstamped one,
      // becomes the goal from now on.
      const double stamp = sim_time_of_stamp(e.input_time) - node_.time_offset_;
      // While paused the simulation's time stands still and ROS time does not: a stamp then says
      // nothing about when in the simulation the pose is meant, so it is a goal (as unstamped).
      if (e.stamped && !node_.sim_.paused() && stamp > now - corde::PoseTimeline::kMaxDelay &&
          stamp < now + kMaxStampLead) {
        node_.sim_.submit(corde::Command::sample(now, e.grasp, e.pose, stamp));
        break;
      }
      if (e.stamped && !node_.sim_.paused())
        ROS_WARN_THROTTLE(10.0,
                          "corde_sim: pose for grasp '%s' stamped %.3f s %s the simulation's "
                          "time: followed as it arrives, not by its stamp",
                          e.grasp.c_str(), std::abs(stamp - now),
                          stamp > now ? "ahead of" : "behind");
      node_.sim_.submit(corde::Command::goal(now, e.grasp, e.pose, interval));
      break;
    }
    case InputEvent::Kind::kFrame: {
      GraspWiring& wr = w->second;
      const corde::GraspState* g = node_.grasps_.find(e.grasp);
      if (wr.source != GraspSource::kTf || !g || !g->held || e.input_time <= wr.last_input_time)
        break;
      if (wr.scripted)
        node_.scene_.end_script(e.grasp,
                                ("follows tf frame '" + wr.frame + "' from now on").c_str());
      if (!wr.attached) {
        node_.grasps_.attach(node_.world_, e.grasp, e.pose, wr.snap ? &wr.offset : nullptr,
                             node_.world_.time());
        node_.sim_.mark_good();  // a rollback goes back to the attached grasp, not before it
        wr.attached = true;
        ROS_INFO("corde_sim: grasp '%s' now follows frame '%s'", e.grasp.c_str(), wr.frame.c_str());
      } else {
        const double interval = wr.last_input_time < 0.0 ? 0.0 : e.input_time - wr.last_input_time;
        node_.sim_.submit(corde::Command::goal(node_.world_.time(), e.grasp, e.pose,
                                               ros_to_sim_interval(interval)));
      }
      wr.last_input_time = e.input_time;
      break;
    }
    case InputEvent::Kind::kWrench:
      node_.sim_.submit(corde::Command::wrench(node_.world_.time(), e.grasp, e.force, e.torque));
      break;
    case InputEvent::Kind::kTwistRate:
      node_.sim_.submit(corde::Command::twist_rate(node_.world_.time(), e.grasp, e.rate));
      break;
    case InputEvent::Kind::kGrip:
      node_.sim_.submit(corde::Command::grip(node_.world_.time(), e.grasp, e.grip_force));
      break;
  }
}

void NodeInputs::apply_reconfigure(const NodeConfig& c) {
  if (c.real_time_factor != node_.params_.real_time_factor) {
    node_.params_.real_time_factor = c.real_time_factor;
    node_.clock_.set_factor(c.real_time_factor, node_.sim_time(), wall_seconds(),
                            static_cast<std::int64_t>(ros::Time::now().toNSec()));
  }
  node_.params_.tf_rate = c.tf_rate;
  node_.params_.marker_rate = c.marker_rate;
  node_.params_.state_rate = c.state_rate;
  node_.outputs_.schedule().set_rate(OutputSchedule::kTf, c.tf_rate);
  node_.outputs_.schedule().set_rate(OutputSchedule::kMarkers, c.marker_rate);
  node_.outputs_.schedule().set_rate(OutputSchedule::kState,
                                     c.state_rate > 0.0 ? c.state_rate : 2.0);
  const MarkerStyle style =
      c.marker_style == "line_strip" ? MarkerStyle::kLineStrip : MarkerStyle::kCylinders;
  if (style != node_.params_.marker_style || c.show_frames != node_.params_.show_frames)
    node_.outputs_.clear_markers();  // the old style's markers go
  node_.params_.marker_style = style;
  node_.params_.show_frames = c.show_frames;
  node_.params_.color_by_strain = c.color_by_strain;
  node_.params_.marker_min_diameter = c.marker_min_diameter;
  node_.params_.holder_max_speed = c.holder_max_speed;
  node_.params_.holder_max_acceleration = c.holder_max_acceleration;
  corde::HolderLimits limits = node_.sim_.holder_limits();  // configuration: never rolled back
  limits.max_speed = c.holder_max_speed;
  limits.max_acceleration = c.holder_max_acceleration;
  node_.sim_.set_holder_limits(limits);
  ROS_INFO(
      "corde_sim: reconfigured: real_time_factor %g, tf/marker/state rates %g/%g/%g Hz, markers "
      "%s%s, holder limits %g m/s, %g m/s^2",
      c.real_time_factor, c.tf_rate, c.marker_rate, c.state_rate, c.marker_style.c_str(),
      c.show_frames ? " with frames" : "", c.holder_max_speed, c.holder_max_acceleration);
}

void NodeInputs::wait_for_robot(double timeout) {
  RobotObstacles& robot = node_.scene_.robot();
  if (robot.empty()) return;
  const double end = wall_seconds() + timeout;
  bool said = false;
  while (ros::ok()) {
    update_robot();
    const std::string missing = robot.unseen_links();
    if (missing.empty()) {
      if (said) ROS_INFO("corde_sim: the robot's links are in tf: starting");
      return;
    }
    if (wall_seconds() >= end) {
      ROS_WARN(
          "corde_sim: starting without the robot's links %s: not in tf after "
          "~robot_start_timeout (%g s); they collide from when they appear",
          missing.c_str(), timeout);
      return;
    }
    if (!said)
      ROS_INFO(
          "corde_sim: waiting for the robot's links in tf before the first step (up to "
          "~robot_start_timeout, %g s): %s",
          timeout, missing.c_str());
    said = true;
    ros::getGlobalCallbackQueue()->callAvailable(ros::WallDuration(0.02));
  }
}

void NodeInputs::update_robot() {
  RobotObstacles& robot = node_.scene_.robot();
  if (robot.empty()) return;
  const std::string& world = node_.params_.world_frame;
  const ros::Time now = ros::Time::now();
  std::string unseen, stale, fast;
  auto append = [](std::string* list, const std::string& name) {
    *list += (list->empty() ? "" : ", ") + name;
  };
  for (size_t k = 0; k < robot.links().size(); ++k) {
    RobotObstacles::Link& link = robot.links()[k];
    const std::string frame = node_.params_.robot_frame_prefix + link.name;
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    double stamp = 0.0;  // static (or the world frame itself)
    if (frame != world) {
      geometry_msgs::TransformStamped t;
      try {
        if (!tf_buffer_->canTransform(world, frame, ros::Time(0))) {
          append(link.seen ? &stale : &unseen, link.name);
          continue;
        }
        t = tf_buffer_->lookupTransform(world, frame, ros::Time(0));
      } catch (const tf2::TransformException&) {
        append(link.seen ? &stale : &unseen, link.name);
        continue;
      }
      stamp = t.header.stamp.toSec();
      if (stamp > 0.0 && (now - t.header.stamp).toSec() > node_.params_.max_frame_age) {
        append(link.seen ? &stale : &unseen, link.name);
        continue;
      }
      pose = to_eigen(t);
    }
    if (link.seen && stamp <= link.last_stamp) continue;  // nothing new
    if (!pose.matrix().allFinite()) continue;
    const bool first = !link.seen;
    const double interval = first ? 0.0 : ros_to_sim_interval(stamp - link.last_stamp);
    if (!robot.set_link_pose(node_.world_.obstacles.get(), static_cast<int>(k), pose, interval,
                             node_.params_.robot_max_speed, node_.params_.robot_max_angular_speed,
                             kRobotMaxGlideLag))
      append(&fast, link.name);
    link.last_stamp = stamp;
    if (first)
      ROS_INFO(
          "corde_sim: robot link '%s' found in tf (frame '%s'): its %zu collision element(s) "
          "collide from now on",
          link.name.c_str(), frame.c_str(), link.elements.size());
  }
  if (!unseen.empty())
    ROS_WARN_THROTTLE(5.0, "corde_sim: robot links not (yet) in tf, or stale: not colliding: %s",
                      unseen.c_str());
  if (!stale.empty())
    ROS_WARN_THROTTLE(5.0,
                      "corde_sim: robot links whose tf frame is gone or older than "
                      "~max_frame_age (%g s): holding still where last seen: %s",
                      node_.params_.max_frame_age, stale.c_str());
  if (!fast.empty())
    ROS_WARN_THROTTLE(5.0,
                      "corde_sim: robot links moving faster in tf than ~robot_max_speed (%g m/s) "
                      "or ~robot_max_angular_speed (%g rad/s): followed at those speeds: %s",
                      node_.params_.robot_max_speed, node_.params_.robot_max_angular_speed,
                      fast.c_str());
}

}  // namespace corde_sim
