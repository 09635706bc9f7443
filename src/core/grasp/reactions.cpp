#include "corde_sim/grasp/reactions.h"

namespace corde {

Wrench support_reaction(const Rod& rod, const Support& support, const Vec3* point) {
  Wrench w;
  if (point)
    w.point = *point;
  else if (support.midpoint_of >= 0)
    w.point =
        0.5 * (rod.positions()[support.midpoint_of] + rod.positions()[support.midpoint_of + 1]);
  else if (!support.nodes.empty())
    w.point = rod.positions()[support.nodes[0]];
  for (int i : support.nodes) {
    Vec3 f = Vec3::Zero();
    if (const NodeDrive* d = rod.node_drive(i)) f = d->reaction;
    for (const NodeConstraint& c : rod.node_constraints())
      if (c.node == i) f += c.reaction;
    w.force += f;
    w.moment += (rod.positions()[i] - w.point).cross(f);
  }
  for (int s : support.segments) {
    if (const SegmentDrive* d = rod.segment_drive(s)) w.moment += d->reaction;
    for (const SegmentConstraint& c : rod.segment_constraints())
      if (c.segment == s) w.moment += c.reaction;
  }
  if (support.ghost == 0 && rod.ghost_start().active) w.moment += rod.ghost_start().reaction;
  if (support.ghost == 1 && rod.ghost_end().active) w.moment += rod.ghost_end().reaction;
  return w;
}

}  // namespace corde
