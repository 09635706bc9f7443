// Knot topology of an open rod, for tests of knots: the knot determinant of the centreline closed
// far away, and the closest approach of non-neighbouring segments.
#pragma once

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <vector>

#include "corde_sim/contact/segment_distance.h"
#include "corde_sim/rod/rod.h"

namespace corde {

// |Delta(-1)|, the determinant of the knot formed by the centreline extended from both ends along
// the line through them and closed by a far rectangle: 1 for the unknot, 3 for the trefoil (an
// overhand knot), 5 for the figure-eight. It is an invariant (any projection direction gives the
// same value), so it changes only if the rod passes through itself. Computed from the projection
// along `view` as the minor of the colouring matrix: for each crossing, 2 x (over arc) - (the two
// under arcs) (Livingston, "Knot Theory", ch. 3).
inline long knot_determinant(const std::vector<Vec3>& nodes,
                             Vec3 view = Vec3(0.1234, 0.3456, 1.0)) {
  view.normalize();
  const Vec3 axis = (nodes.back() - nodes.front()).normalized();
  Vec3 side = view.cross(axis);
  if (side.norm() < 1e-6) side = view.unitOrthogonal();
  side.normalize();
  Vec3 centre = Vec3::Zero();
  for (const Vec3& p : nodes) centre += p;
  centre /= static_cast<double>(nodes.size());
  double extent = 0.0;
  for (const Vec3& p : nodes) extent = std::max(extent, (p - centre).norm());
  const double far = 10.0 * extent;
  // The closed polygon; its last edge runs back to the first point.
  std::vector<Vec3> p;
  p.push_back(nodes.front() - far * axis + far * side);
  p.push_back(nodes.front() - far * axis);
  p.insert(p.end(), nodes.begin(), nodes.end());
  p.push_back(nodes.back() + far * axis);
  p.push_back(nodes.back() + far * axis + far * side);
  const Vec3 e1 = view.unitOrthogonal(), e2 = view.cross(e1);
  const int m = static_cast<int>(p.size());
  struct Crossing {
    double under, over;  // positions along the polygon: edge index + fraction
  };
  std::vector<Crossing> crossings;
  for (int i = 0; i < m; ++i) {
    const Vec3 &a0 = p[i], &a1 = p[(i + 1) % m];
    const Eigen::Vector2d pa(a0.dot(e1), a0.dot(e2)), da(a1.dot(e1) - pa.x(), a1.dot(e2) - pa.y());
    for (int j = i + 2; j < m; ++j) {
      if (i == 0 && j == m - 1) continue;  // adjacent through the closing edge
      const Vec3 &b0 = p[j], &b1 = p[(j + 1) % m];
      const Eigen::Vector2d pb(b0.dot(e1), b0.dot(e2)),
          db(b1.dot(e1) - pb.x(), b1.dot(e2) - pb.y());
      const double den = da.x() * db.y() - da.y() * db.x();
      if (den == 0.0) continue;
      const Eigen::Vector2d r = pb - pa;
      const double s = (r.x() * db.y() - r.y() * db.x()) / den;
      const double t = (r.x() * da.y() - r.y() * da.x()) / den;
      if (s < 0.0 || s >= 1.0 || t < 0.0 || t >= 1.0) continue;
      const double ha = (a0 + s * (a1 - a0)).dot(view), hb = (b0 + t * (b1 - b0)).dot(view);
      if (ha > hb)
        crossings.push_back({j + t, i + s});
      else
        crossings.push_back({i + s, j + t});
    }
  }
  const int n = static_cast<int>(crossings.size());
  if (n < 3) return 1;  // fewer than three crossings: an unknot
  std::vector<double> unders;
  for (const Crossing& c : crossings) unders.push_back(c.under);
  std::sort(unders.begin(), unders.end());
  // Arc k runs from under-crossing k - 1 to under-crossing k (arc 0 wraps around the end).
  auto arc = [&](double pos) {
    return static_cast<int>(std::lower_bound(unders.begin(), unders.end(), pos) - unders.begin()) %
           n;
  };
  Eigen::MatrixXd colouring = Eigen::MatrixXd::Zero(n, n);
  for (int k = 0; k < n; ++k) {
    const int in = arc(crossings[k].under), out = (in + 1) % n;
    colouring(k, arc(crossings[k].over)) += 2.0;
    colouring(k, in) -= 1.0;
    colouring(k, out) -= 1.0;
  }
  const double det = colouring.topLeftCorner(n - 1, n - 1).fullPivLu().determinant();
  return std::lround(std::abs(det));
}

// Smallest distance between the centrelines of two segments of the rod more than `skip` apart
// along it (the surfaces touch at 2 r); `pair` receives the two segments.
inline double closest_non_neighbours(const Rod& rod, int skip,
                                     std::pair<int, int>* pair = nullptr) {
  const auto& x = rod.positions();
  const int n = rod.num_segments();
  double best = INFINITY;
  for (int i = 0; i < n; ++i)
    for (int j = i + skip + 1; j < n; ++j) {
      const SegmentPair sp = closest_points(x[i], x[i + 1], x[j], x[j + 1]);
      const double d =
          ((x[i] + sp.s * (x[i + 1] - x[i])) - (x[j] + sp.t * (x[j + 1] - x[j]))).norm();
      if (d < best) {
        best = d;
        if (pair) *pair = {i, j};
      }
    }
  return best;
}

}  // namespace corde
