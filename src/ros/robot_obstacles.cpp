#include "corde_sim/ros/robot_obstacles.h"

#include <algorithm>
#include <map>
#include <stdexcept>

namespace corde_sim {

void RobotObstacles::load(const std::string& xml, const std::string& base_dir,
                          const std::string& doc, double friction,
                          const std::vector<std::string>& ignore) {
  std::vector<std::string> names;
  std::vector<corde::UrdfCollision> all = corde::parse_urdf_collisions(xml, base_dir, doc, &names);
  elements_.clear();
  links_.clear();
  friction_ = friction;
  std::map<std::string, int> link_index;
  std::vector<bool> used(ignore.size(), false);
  for (corde::UrdfCollision& c : all) {
    const auto skip = std::find(ignore.begin(), ignore.end(), c.link);
    if (skip != ignore.end()) {
      used[skip - ignore.begin()] = true;
      continue;
    }
    auto it = link_index.find(c.link);
    if (it == link_index.end()) {
      it = link_index.emplace(c.link, static_cast<int>(links_.size())).first;
      links_.push_back(Link{c.link, {}, false, 0.0});
    }
    links_[it->second].elements.push_back(static_cast<int>(elements_.size()));
    Element e;
    c.obstacle.moving = true;
    c.obstacle.friction = friction;
    e.collision = std::move(c);
    elements_.push_back(std::move(e));
  }
  for (size_t i = 0; i < ignore.size(); ++i) {
    // An ignored link the robot lacks is an error: a typo would otherwise leave the gripper
    // colliding with the cable it holds.
    if (!used[i] && std::find(names.begin(), names.end(), ignore[i]) == names.end())
      throw std::runtime_error(doc + ": link '" + ignore[i] +
                               "' (in robot_ignore_links) is not in the robot");
  }
}

std::string RobotObstacles::unseen_links() const {
  std::string list;
  for (const Link& link : links_)
    if (!link.seen && !link.elements.empty()) list += (list.empty() ? "" : ", ") + link.name;
  return list;
}

int RobotObstacles::active() const {
  return static_cast<int>(std::count_if(elements_.begin(), elements_.end(),
                                        [](const Element& e) { return e.index >= 0; }));
}

void RobotObstacles::install(corde::ObstacleSet* set) {
  for (const Link& link : links_)
    for (int i : link.elements) {
      Element& e = elements_[i];
      e.index = -1;
      e.velocity_given = false;
      if (!link.seen) continue;
      corde::Obstacle o = e.collision.obstacle;
      o.pose = e.glide.pose();
      e.index = set->add(o);
    }
}

bool RobotObstacles::set_link_pose(corde::ObstacleSet* set, int k, const Eigen::Isometry3d& pose,
                                   double interval, double max_speed, double max_angular_speed,
                                   double max_lag) {
  Link& link = links_[k];
  bool within = true;
  for (int i : link.elements) {
    Element& e = elements_[i];
    const Eigen::Isometry3d target = pose * e.collision.in_link;
    if (e.index < 0) {
      e.glide.reset(target);
      corde::Obstacle o = e.collision.obstacle;
      o.pose = target;
      e.index = set->add(o);
    } else {
      within = e.glide.glide_to(target, interval, max_speed, max_angular_speed, max_lag) && within;
    }
  }
  link.seen = true;
  return within;
}

void RobotObstacles::before_step(corde::ObstacleSet* set, double h) {
  for (Element& e : elements_)
    if (e.index >= 0) glide_step(set, e.index, &e.glide, &e.velocity_given, h);
}

}  // namespace corde_sim
