// Checks of an obstacle as placed, shared by the scene reader and obstacles added at run time
// (the node's ~add_obstacle), so that both refuse the same obstacles with the same words. Far
// beyond sane bounds the geometry queries fail ("too many iterations in Jacobi transform").
#pragma once

#include <string>

#include "corde_sim/contact/obstacle.h"

namespace corde {

// How far an obstacle reaches as placed (m): the largest coordinate of its origin or its largest
// size (a mesh's vertices are not counted).
double placed_extent(const Obstacle& o);

// "" or why the obstacle is placed too far: "obstacle '<name>' has a position or size of <x> m,
// beyond <max_extent> m".
std::string check_placed_extent(const Obstacle& o, double max_extent);

}  // namespace corde
