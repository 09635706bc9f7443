// corde_sim_node's run-time obstacles: the services' requests turned into RuntimeObstacles calls
// on the loop thread, and their tf frames followed.
#include "corde_sim/ros/node_obstacles.h"

#include <memory>
#include <stdexcept>

#include "corde_sim/ros/input_checks.h"
#include "corde_sim/ros/sim_node.h"

namespace corde_sim {
namespace {

// Like a robot link's: at most this much of a glide under way is carried over (s).
constexpr double kMaxGlideLag = 0.05;

ObstacleRequest to_request(const AddObstacle::Request& req) {
  ObstacleRequest r;
  r.name = req.name;
  r.position = {req.pose.position.x, req.pose.position.y, req.pose.position.z};
  r.orientation = Eigen::Quaterniond(req.pose.orientation.w, req.pose.orientation.x,
                                     req.pose.orientation.y, req.pose.orientation.z);
  r.primitive_type = req.primitive.type;
  r.dimensions.assign(req.primitive.dimensions.begin(), req.primitive.dimensions.end());
  r.vertices.reserve(req.mesh.vertices.size());
  for (const auto& v : req.mesh.vertices) r.vertices.emplace_back(v.x, v.y, v.z);
  r.triangles.reserve(req.mesh.triangles.size());
  for (const auto& t : req.mesh.triangles)
    r.triangles.push_back({t.vertex_indices[0], t.vertex_indices[1], t.vertex_indices[2]});
  r.plane = {req.plane.coef[0], req.plane.coef[1], req.plane.coef[2], req.plane.coef[3]};
  r.friction = req.friction;
  return r;
}

}  // namespace

bool NodeObstacles::on_add(AddObstacle::Request& req, AddObstacle::Response& res) {
  // Checked here, on the service thread: the shape needs no simulation state (a mesh's checks
  // may take a while).
  corde::Obstacle o;
  try {
    o = obstacle_from_request(to_request(req));
  } catch (const std::invalid_argument& e) {
    res.success = false;
    res.message = clip_reply("obstacle '" + clip(req.name) + "' not added: " + e.what());
    return true;
  }
  const bool applied = node_.commands_.call([&](const ReplyPtr& reply) {
    add(req, o, &res);
    reply->set();
  });
  if (!applied) {
    res.success = false;
    res.message = "the node is shutting down";
  }
  res.message = clip_reply(res.message);
  return true;
}

bool NodeObstacles::on_remove(RemoveObstacle::Request& req, RemoveObstacle::Response& res) {
  if (!node_.commands_.call([&](const ReplyPtr& reply) {
        remove(req, &res);
        reply->set();
      })) {
    res.success = false;
    res.message = "the node is shutting down";
  }
  res.message = clip_reply(res.message);
  return true;
}

bool NodeObstacles::on_list(ListObstacles::Request&, ListObstacles::Response& res) {
  return node_.commands_.call([&](const ReplyPtr& reply) {
    list(&res);
    reply->set();
  });
}

void NodeObstacles::add(const AddObstacle::Request& req, const corde::Obstacle& o,
                        AddObstacle::Response* res) {
  res->success = false;
  const std::string who = "obstacle '" + clip(req.name) + "' not added: ";
  // The frame: the world's (fixed), or a tf frame followed from now on.
  std::string frame = req.frame;
  Eigen::Isometry3d frame_pose = Eigen::Isometry3d::Identity();
  if (frame == node_.params_.world_frame) frame.clear();
  if (!frame.empty()) {
    std::string error;
    if (!valid_frame_chars(frame) ||
        !node_.inputs_.lookup_world(frame, ros::Time(0), &frame_pose, &error)) {
      res->message =
          who + (error.empty() ? "frame '" + clip(frame) + "' is not a valid name" : error);
      return;
    }
  }
  bool replaced = false;
  try {
    corde::ObstacleSet* set = own_set();
    replaced = obstacles_.add(set, o, frame, frame_pose, ros::Time::now().toSec(), req.replace);
  } catch (const std::exception& e) {
    res->message = who + e.what();
    return;
  }
  changed();
  res->success = true;
  res->message =
      std::string(replaced ? "replaced" : "added") + " obstacle '" + req.name + "' (" +
      shape_kind_name(o.shape.kind) + ") in frame '" +
      (frame.empty() ? node_.params_.world_frame + "', fixed" : frame + "', following it");
  ROS_INFO("corde_sim: %s", res->message.c_str());
}

void NodeObstacles::remove(const RemoveObstacle::Request& req, RemoveObstacle::Response* res) {
  res->success = false;
  if (!node_.world_.obstacles) {
    res->message = "no run-time obstacle is named '" + clip(req.name) + "'";
    return;
  }
  try {
    obstacles_.remove(own_set(), req.name);
  } catch (const std::exception& e) {
    res->message = e.what();
    return;
  }
  changed();
  res->success = true;
  res->message = "removed obstacle '" + req.name + "'";
  ROS_INFO("corde_sim: %s", res->message.c_str());
}

void NodeObstacles::list(ListObstacles::Response* res) const {
  const auto& entries = obstacles_.entries();
  for (size_t k = 0; k < entries.size(); ++k) {
    const RuntimeObstacles::Entry& e = entries[k];
    res->names.push_back(e.obstacle.name);
    res->frames.push_back(e.frame.empty() ? node_.params_.world_frame : e.frame);
    res->shapes.push_back(shape_kind_name(e.obstacle.shape.kind));
    res->poses.push_back(to_pose_msg(obstacles_.world_pose(static_cast<int>(k))));
    res->in_tf.push_back(e.in_tf);
  }
}

corde::ObstacleSet* NodeObstacles::own_set() {
  corde::World& world = node_.world_;
  if (!world.obstacles || world.obstacles.get() != owned_) {
    // A copy (meshes shared): the scene as loaded (~reset's) keeps its own set.
    auto set = std::make_shared<corde::ObstacleSet>();
    if (world.obstacles)
      for (int i = 0; i < world.obstacles->size(); ++i) set->add(world.obstacles->obstacle(i));
    world.obstacles = set;
    owned_ = set.get();
  }
  return world.obstacles.get();
}

void NodeObstacles::changed() {
  node_.sim_.mark_good();  // the guard's snapshot holds the set as it is now
  node_.outputs_.clear_markers();
}

void NodeObstacles::install() {
  owned_ = nullptr;
  if (obstacles_.entries().empty()) return;
  obstacles_.install(own_set());
}

void NodeObstacles::update_frames() {
  if (obstacles_.entries().empty() || !node_.world_.obstacles) return;
  const double now = ros::Time::now().toSec();
  auto& entries = obstacles_.entries();
  for (size_t k = 0; k < entries.size(); ++k) {
    RuntimeObstacles::Entry& e = entries[k];
    if (e.frame.empty()) continue;
    Eigen::Isometry3d pose;
    std::string error;
    e.in_tf = node_.inputs_.lookup_world(e.frame, ros::Time(0), &pose, &error);
    if (!e.in_tf) {
      ROS_WARN_THROTTLE(5.0, "corde_sim: obstacle '%s' holds still where last seen: %s",
                        e.obstacle.name.c_str(), error.c_str());
      continue;
    }
    if (!pose.matrix().allFinite() || pose.matrix() == e.frame_pose.matrix()) continue;
    const double interval = node_.inputs_.ros_to_sim_interval(now - e.last_stamp);
    e.last_stamp = now;
    if (!obstacles_.set_frame_pose(static_cast<int>(k), pose, interval,
                                   node_.params_.robot_max_speed,
                                   node_.params_.robot_max_angular_speed, kMaxGlideLag))
      ROS_WARN_THROTTLE(5.0,
                        "corde_sim: obstacle '%s': its frame '%s' moves faster than "
                        "~robot_max_speed or ~robot_max_angular_speed: followed at those speeds",
                        e.obstacle.name.c_str(), e.frame.c_str());
  }
}

}  // namespace corde_sim
