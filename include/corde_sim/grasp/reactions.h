// Reactions: the force and moment with which a support (a clamp, a driven or constrained node or
// segment, a grasp) holds a rod, as a load cell in a test rig would read them (with the opposite
// sign: a load cell reads what the rod exerts on the support).
#pragma once

#include <string>
#include <vector>

#include "corde_sim/rod/rod.h"

namespace corde {

// What holds a rod at one place: the nodes and segments whose drives or constraints belong to it,
// and the ghost frame of a clamp (0 start, 1 end, -1 none).
struct Support {
  std::string name;  // e.g. "cable/clamp start", "cable/boundary[2]", a grasp's name
  std::string rod;
  std::vector<int> nodes, segments;
  int ghost = -1;
  int midpoint_of = -1;  // >= 0: moments about this segment's midpoint (a grasp's point)
};

struct Wrench {
  Vec3 force = Vec3::Zero();   // N, world frame, exerted by the support on the rod
  Vec3 moment = Vec3::Zero();  // N m, about `point`
  Vec3 point = Vec3::Zero();   // the support's first node, or the grasped segment's midpoint
};

// The support's wrench over the last step, from the reactions its drives, constraints and ghost
// frame recorded (boundary.h); about the support's first node (or midpoint_of's midpoint), or
// `point` if given. Nodes or segments without a drive or constraint contribute nothing.
Wrench support_reaction(const Rod& rod, const Support& support, const Vec3* point = nullptr);

}  // namespace corde
