#include "corde_sim/contact/obstacle_checks.h"

#include <algorithm>
#include <cstdio>

namespace corde {

double placed_extent(const Obstacle& o) {
  return std::max(o.pose.translation().cwiseAbs().maxCoeff(), o.shape.size.cwiseAbs().maxCoeff());
}

std::string check_placed_extent(const Obstacle& o, double max_extent) {
  const double far = placed_extent(o);
  if (far <= max_extent) return "";  // NaN fails too
  char buf[160];
  std::snprintf(buf, sizeof buf, " has a position or size of %.6g m, beyond %.6g m", far,
                max_extent);
  return "obstacle '" + o.name + "'" + buf;
}

}  // namespace corde
