#include "corde_sim/rod/rod_shape.h"

#include <cmath>
#include <stdexcept>

namespace corde {
namespace {

constexpr double kPi = 3.14159265358979323846;

// Two unit vectors perpendicular to the unit axis a.
void basis(const Vec3& a, Vec3* e1, Vec3* e2) {
  *e1 = (std::abs(a.z()) < 0.9 ? Vec3::UnitZ() : Vec3::UnitX()).cross(a).normalized();
  *e2 = a.cross(*e1);
}

std::vector<Vec3> resample(const std::vector<Vec3>& pts, int elements) {
  std::vector<double> cum(pts.size(), 0.0);
  for (size_t i = 1; i < pts.size(); ++i) cum[i] = cum[i - 1] + (pts[i] - pts[i - 1]).norm();
  const double total = cum.back();
  if (!(total > 0.0)) throw std::invalid_argument("polyline has zero length");
  std::vector<Vec3> out(elements + 1);
  size_t k = 1;
  for (int i = 0; i <= elements; ++i) {
    const double s = total * i / elements;
    while (k + 1 < pts.size() && cum[k] < s) ++k;
    const double seg = cum[k] - cum[k - 1];
    const double a = seg > 0.0 ? (s - cum[k - 1]) / seg : 0.0;
    out[i] = pts[k - 1] + std::min(1.0, std::max(0.0, a)) * (pts[k] - pts[k - 1]);
  }
  return out;
}

}  // namespace

std::vector<Vec3> sample_shape(const RodShape& shape, int elements) {
  if (elements < 1) throw std::invalid_argument("elements must be >= 1");
  std::vector<Vec3> nodes(elements + 1);
  switch (shape.kind) {
    case RodShape::Kind::kStraight: {
      if (!(shape.length > 0.0)) throw std::invalid_argument("length must be > 0");
      if (shape.direction.norm() < 1e-12) throw std::invalid_argument("direction is zero");
      const Vec3 d = shape.direction.normalized();
      for (int i = 0; i <= elements; ++i)
        nodes[i] = shape.start + (shape.length * i / elements) * d;
      break;
    }
    case RodShape::Kind::kHelix: {
      if (!(shape.helix_radius > 0.0) || !(shape.helix_turns > 0.0) || shape.helix_pitch < 0.0)
        throw std::invalid_argument("helix needs radius > 0, turns > 0 and pitch >= 0");
      if (shape.direction.norm() < 1e-12) throw std::invalid_argument("direction is zero");
      const Vec3 a = shape.direction.normalized();
      Vec3 e1, e2;
      basis(a, &e1, &e2);
      // A helix has constant speed in its angle, so equal angles give equal arc lengths.
      const double total = 2.0 * kPi * shape.helix_turns;
      for (int i = 0; i <= elements; ++i) {
        const double phi = total * i / elements;
        nodes[i] = shape.start + shape.helix_radius * (std::cos(phi) * e1 + std::sin(phi) * e2) +
                   (shape.helix_pitch * phi / (2.0 * kPi)) * a;
      }
      break;
    }
    case RodShape::Kind::kPolyline:
      if (shape.points.size() < 2) throw std::invalid_argument("polyline needs >= 2 points");
      nodes = resample(shape.points, elements);
      break;
  }
  return nodes;
}

std::vector<Quat> transport_frames(const std::vector<Vec3>& nodes, const Vec3& reference_d1) {
  const size_t n = nodes.size() - 1;
  std::vector<Quat> q(n);
  Vec3 prev_t = Vec3::Zero();
  Vec3 d1 = reference_d1;
  for (size_t s = 0; s < n; ++s) {
    const Vec3 dr = nodes[s + 1] - nodes[s];
    if (dr.norm() < 1e-12) throw std::invalid_argument("shape has a zero-length segment");
    const Vec3 t = dr.normalized();
    if (s == 0) {
      d1 -= t * t.dot(d1);
      if (d1.norm() < 1e-9) {
        Vec3 e2;
        basis(t, &d1, &e2);
      }
    } else {
      // Parallel transport: rotate d1 by the rotation taking the previous tangent to this one.
      d1 = Quat::FromTwoVectors(prev_t, t) * d1;
      d1 -= t * t.dot(d1);
    }
    d1.normalize();
    Eigen::Matrix3d r;
    r.col(0) = d1;
    r.col(1) = t.cross(d1);
    r.col(2) = t;
    q[s] = Quat(r);
    q[s].normalize();
    if (s > 0 && q[s].coeffs().dot(q[s - 1].coeffs()) < 0.0) q[s].coeffs() *= -1.0;
    prev_t = t;
  }
  return q;
}

Rod build_rod(const RodSpec& spec) {
  const std::vector<Vec3> nodes = sample_shape(spec.shape, spec.elements);
  Rod rod(spec.name, nodes, transport_frames(nodes, spec.shape.reference_d1), spec.section);
  if (spec.rest_shape_created) rod.set_rest_strains_from_state();
  return rod;
}

}  // namespace corde
