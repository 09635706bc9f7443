#include "corde_sim/grasp/friction_grasp.h"

namespace corde {

double grip_arc(const Rod& rod, int segment, const Vec3& point, const Vec3& axis,
                double* fraction) {
  const Vec3& x0 = rod.positions()[segment];
  const double along = (rod.positions()[segment + 1] - x0).dot(axis);
  const double l = rod.rest_lengths()[segment];
  // A segment across the axis (a cable folded in the fingers): its midpoint.
  const double f = along > 1e-9 * l ? (point - x0).dot(axis) / along : 0.5;
  double s = 0.0;
  for (int i = 0; i < segment; ++i) s += rod.rest_lengths()[i];
  if (fraction) *fraction = f;
  return s + f * l;
}

void hold_sliding(Rod& rod, const Grasp& grasp, const Vec3& point, const Vec3& axis,
                  const Vec3& velocity) {
  for (int k = 0; k < 2; ++k) {
    const int node = grasp.segment + k;
    const NodeDrive* d = rod.node_drive(node);
    if (d && d->kind == NodeDrive::Kind::kTarget) rod.remove_node_drive(node);
    NodeConstraint c;
    c.kind = NodeConstraint::Kind::kLine;
    c.node = node;
    c.point = point;
    c.direction = axis;
    c.velocity = velocity;
    rod.add_node_constraint(c);  // replaces the one it had
  }
  const SegmentDrive* d = rod.segment_drive(grasp.segment);
  if (d && d->kind == SegmentDrive::Kind::kTarget) rod.remove_segment_drive(grasp.segment);
}

void hold_turning(Rod& rod, const Grasp& grasp, const Vec3& axis) {
  const SegmentDrive* d = rod.segment_drive(grasp.segment);
  if (d && d->kind == SegmentDrive::Kind::kTarget) rod.remove_segment_drive(grasp.segment);
  SegmentConstraint c;
  c.segment = grasp.segment;
  c.origin = rod.orientations()[grasp.segment];
  c.axis = axis;
  rod.add_segment_constraint(c);  // replaces the one it had
}

void release_turning(Rod& rod, const Grasp& grasp) { rod.remove_segment_constraint(grasp.segment); }

void release_sliding(Rod& rod, const Grasp& grasp) {
  for (int k = 0; k < 2; ++k) rod.remove_node_constraint(grasp.segment + k);
}

bool node_taken(const Rod& rod, int node, int segment) {
  if (node == segment || node == segment + 1) return false;
  if (rod.node_drive(node)) return true;
  for (const NodeConstraint& c : rod.node_constraints())
    if (c.node == node) return true;
  return false;
}

}  // namespace corde
