// Checks of an obstacle's values, shared by the scene reader (`obstacles` entries) and whatever
// adds obstacles at run time (a service), so that both accept the same obstacles: within these
// bounds (scene/scene_bounds.h) the geometry queries stay finite.
#pragma once

#include <string>

#include "corde_sim/contact/obstacle.h"

namespace corde {

// "" when a primitive obstacle's own values are those a scene entry may give: friction in
// [0, SceneBounds::max_factor]; box sides, sphere radius, cylinder and capsule radius and length
// in (0, SceneBounds::max_length] m; a finite pose with a rotation. Otherwise the reason, naming
// the value ("box side 0 must be > 0 m, got -1"). A mesh's size is not checked here (ObstacleSet
// refuses an empty or non-finite mesh).
std::string obstacle_value_error(const Obstacle& o);

// "" when the obstacle as placed (position and size) lies within SceneBounds::max_placed_length;
// otherwise "obstacle 'NAME' has a position or size of X m, beyond Y m".
std::string obstacle_placement_error(const Obstacle& o);

}  // namespace corde
