// corde_sim_node's run-time obstacles: ~add_obstacle, ~remove_obstacle, ~list_obstacles, and the
// tf frames such obstacles follow. The service callbacks run on the service threads and wait
// until the loop has applied their command (command_queue.h); everything else runs on the loop
// thread. The bookkeeping (checks, stable indices, glides) is RuntimeObstacles'.
#pragma once

#include "corde_sim/AddObstacle.h"
#include "corde_sim/ListObstacles.h"
#include "corde_sim/RemoveObstacle.h"
#include "corde_sim/contact/obstacle.h"
#include "corde_sim/ros/runtime_obstacles.h"

namespace corde_sim {

class SimNode;

class NodeObstacles {
 public:
  explicit NodeObstacles(SimNode* node) : node_(*node) {}
  // (service threads)
  bool on_add(AddObstacle::Request& req, AddObstacle::Response& res);
  bool on_remove(RemoveObstacle::Request& req, RemoveObstacle::Response& res);
  bool on_list(ListObstacles::Request& req, ListObstacles::Response& res);
  // (loop) A new world (start-up, reset): the run-time obstacles join its obstacles.
  void install();
  // (loop) Obstacles in tf frames glide to where their frames are now.
  void update_frames();
  // (loop) Before each world step of h seconds (the driver's obstacle mover); allocates nothing.
  void before_step(corde::ObstacleSet* set, double h) { obstacles_.before_step(set, h); }
  bool empty() const { return obstacles_.entries().empty(); }

 private:
  // `o`: the request's obstacle, checked on the service thread (obstacle_from_request).
  void add(const AddObstacle::Request& req, const corde::Obstacle& o, AddObstacle::Response* res);
  void remove(const RemoveObstacle::Request& req, RemoveObstacle::Response* res);
  void list(ListObstacles::Response* res) const;
  // The world's obstacle set, made the node's own first (a copy: the scene as loaded keeps its
  // set for ~reset).
  corde::ObstacleSet* own_set();
  // After a change: the guard's state to go back to holds it, the markers are redrawn.
  void changed();

  SimNode& node_;
  RuntimeObstacles obstacles_;
  const corde::ObstacleSet* owned_ = nullptr;  // the set own_set() made
};

}  // namespace corde_sim
