// SimNode: a robot's links as moving obstacles. The URDF's collision elements (from a parameter
// or a file) follow their links' tf frames: each new frame pose is glided to over the interval
// since the previous one (ObstacleGlide), so the contacts see the link's velocity.
#include <ros/console.h>

#include <filesystem>

#include "corde_sim/io/file_read.h"
#include "corde_sim/ros/input_checks.h"
#include "corde_sim/ros/sim_node.h"
#include "corde_sim/scene/scene.h"

namespace corde_sim {

namespace {
// s of simulation time a link's glide may run behind its tf poses beyond one interval: covers
// the jitter with which poses arrive and are picked up (up to about 20 ms measured with a
// loaded 2-core machine and tf at 100 Hz), so that jitter does not change the link's speed,
// while a simulation slower than real time still follows the robot closely.
constexpr double kRobotMaxGlideLag = 0.05;
}  // namespace

void SimNode::load_robot() {
  const bool from_file = !params_.robot_urdf_file.empty();
  if (!from_file && !params_.robot_collision) return;
  // A robot asked for explicitly that cannot be read stops the node (like a bad scene): running
  // without some of its links would let them pass through the cable unnoticed.
  std::string xml, base_dir, doc, param;
  if (from_file) {
    param = "robot_urdf_file";
    // Regular files only, bounded (a FIFO would block the node, /dev/zero exhaust its memory).
    try {
      xml = corde::read_input_file(params_.robot_urdf_file, "URDF",
                                   corde::SceneLimits::max_urdf_bytes);
    } catch (const corde::FileError& e) {
      throw std::invalid_argument(std::string("parameter ~robot_urdf_file: ") + e.what());
    }
    base_dir = std::filesystem::path(params_.robot_urdf_file).parent_path().string();
    doc = params_.robot_urdf_file;
  } else {
    param = "robot_collision";
    // Resolved like robot_state_publisher's: relative to the node's namespace.
    const std::string name = nh_.resolveName(params_.robot_description);
    if (!ros::param::get(name, xml))
      throw std::invalid_argument("parameter ~robot_collision: true, but parameter " + name +
                                  " (~robot_description) holds no URDF string");
    doc = "parameter " + name;
  }
  try {
    robot_.load(xml, base_dir, doc, params_.robot_friction, params_.robot_ignore_links);
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

void SimNode::install_robot() {
  if (robot_.empty()) return;
  // A set of our own: the scene's obstacles (copied, meshes shared) and the robot's, so that
  // links added later never touch the set of the scene as loaded.
  auto set = std::make_shared<corde::ObstacleSet>();
  if (world_.obstacles)
    for (int i = 0; i < world_.obstacles->size(); ++i) set->add(world_.obstacles->obstacle(i));
  robot_.install(set.get());
  world_.obstacles = set;
}

void SimNode::update_robot() {
  if (robot_.empty()) return;
  const std::string& world = params_.world_frame;
  const ros::Time now = ros::Time::now();
  std::string unseen, stale, fast;
  auto append = [](std::string* list, const std::string& name) {
    *list += (list->empty() ? "" : ", ") + name;
  };
  for (size_t k = 0; k < robot_.links().size(); ++k) {
    RobotObstacles::Link& link = robot_.links()[k];
    const std::string frame = params_.robot_frame_prefix + link.name;
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
      if (stamp > 0.0 && (now - t.header.stamp).toSec() > params_.max_frame_age) {
        append(link.seen ? &stale : &unseen, link.name);
        continue;
      }
      pose = to_eigen(t);
    }
    if (link.seen && stamp <= link.last_stamp) continue;  // nothing new
    if (!pose.matrix().allFinite()) continue;
    const bool first = !link.seen;
    const double interval = first ? 0.0 : ros_to_sim_interval(stamp - link.last_stamp);
    if (!robot_.set_link_pose(world_.obstacles.get(), static_cast<int>(k), pose, interval,
                              params_.robot_max_speed, params_.robot_max_angular_speed,
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
                      params_.max_frame_age, stale.c_str());
  if (!fast.empty())
    ROS_WARN_THROTTLE(5.0,
                      "corde_sim: robot links moving faster in tf than ~robot_max_speed (%g m/s) "
                      "or ~robot_max_angular_speed (%g rad/s): followed at those speeds: %s",
                      params_.robot_max_speed, params_.robot_max_angular_speed, fast.c_str());
}

}  // namespace corde_sim
