// Is a state fit to continue from and to show? A blown-up explicit step does not always end in
// NaN: it can leave finite garbage (zero quaternions, angular velocities of 1e100). These checks
// catch that early, so a caller can fall back on the last state that passed them.
#pragma once

#include <string>

#include "corde_sim/world/world.h"

namespace corde {

struct ValidityLimits {
  // A node faster than this, or a segment spinning faster than this, means the step has lost
  // stability: no cable in a manipulation scene moves at 100 m/s, and a blow-up grows
  // geometrically, so it crosses these bounds within a few steps of starting.
  double max_speed = 100.0;            // m/s
  double max_angular_speed = 1e5;      // rad/s
  double quaternion_tolerance = 1e-6;  // | |q| - 1 | (the step renormalises)
};

// "" if every rod is finite, its quaternions are unit, and its nodes and segments move slower
// than the limits; otherwise the first problem found, naming the rod and the item.
std::string validity_problem(const World& world, const ValidityLimits& limits);

}  // namespace corde
