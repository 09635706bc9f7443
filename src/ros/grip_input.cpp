// Grip force inputs: the check shared by grasps/<name>/grip and ~set_grip, and ~set_grip itself.
#include "corde_sim/ros/grip_input.h"

#include <cmath>

#include "corde_sim/ros/input_checks.h"
#include "corde_sim/ros/node_services.h"
#include "corde_sim/ros/sim_node.h"

namespace corde_sim {

std::string check_grip(const corde::GraspSet& grasps, const std::string& name, double force) {
  if (!std::isfinite(force) || force < 0.0 || force > kMaxGripForce)
    return "grip force must be finite, >= 0 and at most " + num(kMaxGripForce) + " N, got " +
           num(force);
  const corde::GraspState* g = grasps.find(name);
  if (!g) return "no grasp named '" + clip(name) + "'";
  if (!g->spec.grip.friction)
    return "grasp '" + name +
           "' holds rigidly, not by friction (give it a grip: {force, mu} in the scene)";
  if (!g->held || !g->grip.on) return "grasp '" + name + "' is released";
  return "";
}

bool NodeServices::on_set_grip(SetGrip::Request& req, SetGrip::Response& res) {
  if (!in_loop([&] { set_grip(req, res); })) {
    res.success = false;
    res.message = "the node is shutting down";
  }
  return true;
}

void NodeServices::set_grip(SetGrip::Request& req, SetGrip::Response& res) {
  res.success = false;
  res.message = check_grip(node_.grasps_, req.name, req.force);
  if (!res.message.empty()) {
    res.message = "grip unchanged: " + res.message;
    return;
  }
  // Through the driver, behind the inputs that arrived before it; applied now, so that the reply
  // holds.
  node_.sim_.submit(corde::Command::grip(node_.world_.time(), req.name, req.force));
  node_.sim_.apply_due();
  const corde::GraspState* g = node_.grasps_.find(req.name);
  res.success = true;
  res.message = "grasp '" + req.name + "' grips with " + num(req.force) +
                " N: holds up to mu N = " + num(g->grip.mu * req.force) + " N along the cable";
  ROS_INFO("corde_sim: %s", res.message.c_str());
  node_.sim_.mark_good();
}

}  // namespace corde_sim
