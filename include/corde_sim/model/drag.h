// Drag of the surrounding air (or fluid) on a rod's nodes: its coefficients and their one
// evaluation per node, shared by the explicit force (Rod) and the implicit step's drag matrix.
#pragma once

#include <algorithm>
#include <vector>

#include "corde_sim/math/types.h"

namespace corde {

// Drag of the fluid at rest, per unit length of rod, split into the components of the velocity
// normal and tangential to the rod: f = -(c_n v_n + c_t v_t) - (q_n |v_n| v_n + q_t |v_t| v_t)
// (N/m). From a fluid of density rho_f and a normal drag coefficient C_d on a cylinder of
// diameter 2r: q_n = rho_f C_d r (= 1/2 rho_f C_d 2r).
struct Drag {
  double linear_normal = 0.0;         // c_n (N s/m^2)
  double linear_tangential = 0.0;     // c_t (N s/m^2)
  double quadratic_normal = 0.0;      // q_n (N s^2/m^3)
  double quadratic_tangential = 0.0;  // q_t (N s^2/m^3)
  bool active() const {
    return linear_normal > 0.0 || linear_tangential > 0.0 || quadratic_normal > 0.0 ||
           quadratic_tangential > 0.0;
  }
};

// The drag on one node at velocity v: the rod's direction there, its velocity split along and
// across it, and the coefficients per unit length at that velocity (the quadratic terms taken at
// |v_n|, |v_t|), for the length of rod the node stands for.
struct NodeDrag {
  Vec3 tangent;             // unit; zero where the chord across the node vanishes
  Vec3 v_normal;            // v - v_tangential
  Vec3 v_tangential;        // (v . tangent) tangent
  double normal = 0.0;      // c_n + q_n |v_n| (N s/m^2)
  double tangential = 0.0;  // c_t + q_t |v_t| (N s/m^2)
  double length = 0.0;      // the node's mass over the mass per length (m)
};

// Node i of the rod whose nodes are at x: its direction is the chord across it (from node i - 1
// to node i + 1, clamped at the ends), the length it stands for its mass over the mass per length
// (half of each adjacent segment's rest length).
inline NodeDrag node_drag(const Drag& d, const std::vector<Vec3>& x, int i, const Vec3& v,
                          double node_mass, double inv_mass_per_length) {
  const int n = static_cast<int>(x.size()) - 1;
  NodeDrag r;
  const Vec3 chord = x[std::min(i + 1, n)] - x[std::max(i - 1, 0)];
  const double len = chord.norm();
  r.tangent = len > 0.0 ? Vec3(chord / len) : Vec3::Zero();
  r.v_tangential = v.dot(r.tangent) * r.tangent;
  r.v_normal = v - r.v_tangential;
  r.normal = d.linear_normal + d.quadratic_normal * r.v_normal.norm();
  r.tangential = d.linear_tangential + d.quadratic_tangential * r.v_tangential.norm();
  r.length = node_mass * inv_mass_per_length;
  return r;
}

// The drag force on the node (N).
inline Vec3 drag_force(const NodeDrag& n) {
  return n.length * Vec3(-n.normal * n.v_normal - n.tangential * n.v_tangential);
}

// The node's drag matrix D (N s/m), the force being -D v with the coefficients held: the normal
// coefficient across the tangent, the tangential one along it.
inline Mat3 drag_matrix(const NodeDrag& n) {
  const Mat3 tt = n.tangent * n.tangent.transpose();
  return n.length * (n.normal * (Mat3::Identity() - tt) + n.tangential * tt);
}

}  // namespace corde
