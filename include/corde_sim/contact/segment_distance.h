// Closest points between two line segments (rod segments' axes), for rod-rod and self contact.
#pragma once

#include <algorithm>

#include "corde_sim/model/element_energies.h"

namespace corde {

struct SegmentPair {
  double s = 0.0, t = 0.0;  // the points p0 + s (p1 - p0) and q0 + t (q1 - q0), s, t in [0, 1]
};

// The parameters of the closest points of [p0, p1] and [q0, q1]. Minimises
// |p0 + s d1 - q0 - t d2|^2 over the unit square: the unconstrained minimum clamped to it, then
// each parameter re-solved for the other's clamped value. Parallel segments (and points) get one
// of their closest pairs.
inline SegmentPair closest_points(const Vec3& p0, const Vec3& p1, const Vec3& q0, const Vec3& q1) {
  const Vec3 d1 = p1 - p0, d2 = q1 - q0, r = p0 - q0;
  const double a = d1.squaredNorm(), e = d2.squaredNorm(), f = d2.dot(r);
  const double tiny = 1e-300;
  SegmentPair out;
  if (a <= tiny && e <= tiny) return out;
  if (a <= tiny) {
    out.t = std::clamp(f / e, 0.0, 1.0);
    return out;
  }
  const double c = d1.dot(r);
  if (e <= tiny) {
    out.s = std::clamp(-c / a, 0.0, 1.0);
    return out;
  }
  const double b = d1.dot(d2), denom = a * e - b * b;
  // Parallel (denom ~ 0): any s; take 0 and let t and s follow.
  double s = denom > 1e-14 * a * e ? std::clamp((b * f - c * e) / denom, 0.0, 1.0) : 0.0;
  double t = (b * s + f) / e;
  if (t < 0.0) {
    t = 0.0;
    s = std::clamp(-c / a, 0.0, 1.0);
  } else if (t > 1.0) {
    t = 1.0;
    s = std::clamp((b - c) / a, 0.0, 1.0);
  }
  out.s = s;
  out.t = t;
  return out;
}

}  // namespace corde
