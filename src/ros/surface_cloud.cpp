#include "corde_sim/ros/surface_cloud.h"

#include <cmath>

namespace corde_sim {

void append_surface_points(const corde::Rod& rod, int rings_per_segment, int points_per_ring,
                           std::vector<float>* xyz) {
  const std::vector<corde::Vec3>& x = rod.positions();
  const double r = rod.section().radius;
  const int n = rod.num_segments();
  xyz->reserve(xyz->size() + 3 * static_cast<size_t>(n) * rings_per_segment * points_per_ring);
  // The ring's directions: cos/sin of each point's angle, the same for every ring.
  std::vector<double> c(points_per_ring), s(points_per_ring);
  for (int k = 0; k < points_per_ring; ++k) {
    const double a = 2.0 * M_PI * k / points_per_ring;
    c[k] = std::cos(a);
    s[k] = std::sin(a);
  }
  for (int seg = 0; seg < n; ++seg) {
    const corde::Vec3 d = x[seg + 1] - x[seg];
    // Any two unit vectors across the axis (a zero-length segment: across z).
    const corde::Vec3 t = d.norm() > 0.0 ? corde::Vec3(d.normalized()) : corde::Vec3::UnitZ();
    const corde::Vec3 u = t.unitOrthogonal();
    const corde::Vec3 v = t.cross(u);
    for (int j = 0; j < rings_per_segment; ++j) {
      const corde::Vec3 centre = x[seg] + ((j + 0.5) / rings_per_segment) * d;
      for (int k = 0; k < points_per_ring; ++k) {
        const corde::Vec3 p = centre + r * (c[k] * u + s[k] * v);
        xyz->push_back(static_cast<float>(p.x()));
        xyz->push_back(static_cast<float>(p.y()));
        xyz->push_back(static_cast<float>(p.z()));
      }
    }
  }
}

}  // namespace corde_sim
