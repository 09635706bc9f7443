// The contact solve's one way of reading a contact's relative velocity from per-rod node
// velocities (contact.cpp and contact_delassus.cpp), so that the sweeps, the rounds, the Delassus
// solve and the BDF2 retake all measure a contact alike.
#pragma once

#include <vector>

#include "corde_sim/contact/contact.h"

namespace corde {

// The velocity of contact c's point on rod a (interpolated along its segment at s_a) less that of
// its point on rod b (at s_b), from per-rod node velocities `vel`. With an obstacle, `absolute`
// takes the obstacle's surface velocity off too (false: a change of velocities, which the obstacle
// does not have).
inline Vec3 relative_velocity(const Contact& c, const std::vector<std::vector<Vec3>>& vel,
                              bool absolute) {
  Vec3 v = (1.0 - c.s_a) * vel[c.rod_a][c.seg_a] + c.s_a * vel[c.rod_a][c.seg_a + 1];
  if (c.rod_b >= 0)
    v -= (1.0 - c.s_b) * vel[c.rod_b][c.seg_b] + c.s_b * vel[c.rod_b][c.seg_b + 1];
  else if (absolute)
    v -= c.surface_velocity;
  return v;
}

}  // namespace corde
