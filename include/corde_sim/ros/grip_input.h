// A friction grasp's grip force set at run time: the topic grasps/<name>/grip (std_msgs/Float64,
// N) and the service ~set_grip. Both are checked the same way and go through the node's command
// queue to the driver (corde::Command::grip), so a grip change applies between steps.
#pragma once

#include <string>

#include "corde_sim/grasp/grasp_set.h"

namespace corde_sim {

constexpr double kMaxGripForce = 1e6;  // N

// "" when grasp `name` of `grasps` is a held friction grasp (scene key grip: {force, mu}) and
// `force` is a grip force (finite, >= 0, at most kMaxGripForce N); else why not, naming both.
std::string check_grip(const corde::GraspSet& grasps, const std::string& name, double force);

}  // namespace corde_sim
