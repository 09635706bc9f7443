// Twist and writhe of a rod, for tests of twisted rods (Calugareanu-White: Lk = Tw + Wr).
#pragma once

#include <algorithm>
#include <cmath>
#include <vector>

#include "corde_sim/rod/rod.h"

namespace corde {

// Rotation angle from frame a to frame b about the shared tangent after parallel transport:
// the twist of one element (rad).
inline double element_twist(const Quat& a, const Quat& b) {
  const Vec3 t0 = a * Vec3::UnitZ(), t1 = b * Vec3::UnitZ();
  const Quat transport = Quat::FromTwoVectors(t0, t1);
  const Vec3 d1 = transport * (a * Vec3::UnitX());
  const Vec3 e1 = b * Vec3::UnitX(), e2 = b * Vec3::UnitY();
  return std::atan2(-d1.dot(e2), d1.dot(e1));
}

// Twist of the rod in turns: its elements and the ghost-frame elements of its clamps.
inline double twist_turns(const Rod& rod) {
  const auto& q = rod.orientations();
  double tw = 0.0;
  if (rod.ghost_start().active) tw += element_twist(rod.ghost_start().frame, q.front());
  for (size_t j = 0; j + 1 < q.size(); ++j) tw += element_twist(q[j], q[j + 1]);
  if (rod.ghost_end().active) tw += element_twist(q.back(), rod.ghost_end().frame);
  return tw / (2.0 * M_PI);
}

// Writhe of the centreline extended from both ends along the line through them to a great
// distance (the closure at infinity of Fuller and White), summed exactly over pairs of straight
// segments with the solid-angle formula of Klenin & Langowski, "Computation of writhe in modeling
// of supercoiled DNA" (Biopolymers 2000).
inline double writhe(const Rod& rod) {
  std::vector<Vec3> p = rod.positions();
  const Vec3 axis = (p.back() - p.front()).normalized();
  const double far = 1e4 * (p.back() - p.front()).norm();
  p.insert(p.begin(), p.front() - far * axis);
  p.push_back(p.back() + far * axis);
  auto unit_cross = [](const Vec3& a, const Vec3& b) {
    const Vec3 c = a.cross(b);
    const double n = c.norm();
    return n > 0.0 ? Vec3(c / n) : Vec3(Vec3::Zero());
  };
  auto clamp_asin = [](double x) { return std::asin(std::clamp(x, -1.0, 1.0)); };
  double wr = 0.0;
  const size_t n = p.size() - 1;
  for (size_t i = 0; i < n; ++i)
    for (size_t j = i + 2; j < n; ++j) {
      const Vec3 &p1 = p[i], &p2 = p[i + 1], &p3 = p[j], &p4 = p[j + 1];
      const Vec3 r13 = p3 - p1, r14 = p4 - p1, r23 = p3 - p2, r24 = p4 - p2;
      const Vec3 n1 = unit_cross(r13, r14), n2 = unit_cross(r14, r24);
      const Vec3 n3 = unit_cross(r24, r23), n4 = unit_cross(r23, r13);
      const double omega = clamp_asin(n1.dot(n2)) + clamp_asin(n2.dot(n3)) +
                           clamp_asin(n3.dot(n4)) + clamp_asin(n4.dot(n1));
      const double sign = (p4 - p3).cross(p2 - p1).dot(r13) >= 0.0 ? 1.0 : -1.0;
      wr += 2.0 * sign * omega;
    }
  return wr / (4.0 * M_PI);
}

}  // namespace corde
