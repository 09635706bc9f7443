// Obstacle queries. The plane, spheres and capsules are analytic (closed forms, exact, no FCL
// pitfalls); boxes, cylinders and meshes go through FCL 0.7, with analytic signed distances where
// FCL has no answer (the axis touching or inside a box or cylinder) and contacts for meshes.
#include "corde_sim/contact/obstacle.h"

#include <fcl/fcl.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <sstream>
#include <stdexcept>
#include <utility>

namespace corde {

namespace {

using Box3 = Eigen::AlignedBox3d;

// FCL's GJK stops at this change of the distance (its default, 1e-6, leaves cylinders' closest
// points 1e-6 off: their support function is round).
constexpr double kGjkTolerance = 1e-10;

// Closest point of segment [a, b] to c, as the parameter s in [0, 1].
double closest_s(const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 d = b - a;
  const double dd = d.squaredNorm();
  if (dd <= 0.0) return 0.0;
  return std::clamp((c - a).dot(d) / dd, 0.0, 1.0);
}

// Closest points of segments p(s) = p0 + s (p1 - p0) and q(t) = q0 + t (q1 - q0), s, t in [0, 1]
// (the classic clamped solution of the 2x2 normal equations; parallel segments take s = 0 first).
void segment_segment(const Vec3& p0, const Vec3& p1, const Vec3& q0, const Vec3& q1, double* s,
                     double* t) {
  const Vec3 d1 = p1 - p0, d2 = q1 - q0, r = p0 - q0;
  const double a = d1.squaredNorm(), e = d2.squaredNorm(), f = d2.dot(r);
  constexpr double kTiny = 1e-300;
  if (a <= kTiny && e <= kTiny) {
    *s = *t = 0.0;
    return;
  }
  if (a <= kTiny) {
    *s = 0.0;
    *t = std::clamp(f / e, 0.0, 1.0);
    return;
  }
  const double c = d1.dot(r);
  if (e <= kTiny) {
    *t = 0.0;
    *s = std::clamp(-c / a, 0.0, 1.0);
    return;
  }
  const double b = d1.dot(d2), denom = a * e - b * b;
  // Near-parallel segments: any s works for the line distance; s = 0 and the clamping below give a
  // closest pair.
  *s = denom > 1e-14 * a * e ? std::clamp((b * f - c * e) / denom, 0.0, 1.0) : 0.0;
  *t = (b * *s + f) / e;
  if (*t < 0.0) {
    *t = 0.0;
    *s = std::clamp(-c / a, 0.0, 1.0);
  } else if (*t > 1.0) {
    *t = 1.0;
    *s = std::clamp((b - c) / a, 0.0, 1.0);
  }
}

// A point's signed distance to a primitive's surface in the primitive's frame, with the closest
// surface point and the outward normal there: q + d n = p (also inside, where d < 0).
struct LocalSdf {
  double d;
  Vec3 q, n;
};

// Box of half sizes h centred at the origin.
LocalSdf box_sdf(const Vec3& p, const Vec3& h) {
  const Vec3 q = p.cwiseMax(-h).cwiseMin(h);
  const double out = (p - q).norm();
  if (out > 0.0) return {out, q, (p - q) / out};
  // Inside or on the surface: the nearest face.
  int k = 0;
  double depth = h[0] - std::abs(p[0]);
  for (int i = 1; i < 3; ++i) {
    const double di = h[i] - std::abs(p[i]);
    if (di < depth) depth = di, k = i;
  }
  const double sign = p[k] < 0.0 ? -1.0 : 1.0;
  LocalSdf r{-depth, p, Vec3::Zero()};
  r.q[k] = sign * h[k];
  r.n[k] = sign;
  return r;
}

// Cylinder of radius rad around z, half length hl, centred at the origin.
LocalSdf cylinder_sdf(const Vec3& p, double rad, double hl) {
  const double rho = std::hypot(p.x(), p.y());
  // Radial direction; any one on the axis.
  const Vec3 er = rho > 0.0 ? Vec3(p.x() / rho, p.y() / rho, 0.0) : Vec3::UnitX();
  if (rho > rad || std::abs(p.z()) > hl) {
    const Vec3 q = std::min(rho, rad) * er + std::clamp(p.z(), -hl, hl) * Vec3::UnitZ();
    const double d = (p - q).norm();
    return {d, q, (p - q) / d};
  }
  const double dr = rad - rho, dz = hl - std::abs(p.z());
  if (dr < dz) return {-dr, rad * er + p.z() * Vec3::UnitZ(), er};
  const double sign = p.z() < 0.0 ? -1.0 : 1.0;
  return {-dz, Vec3(p.x(), p.y(), sign * hl), sign * Vec3::UnitZ()};
}

// Minimum over s in [lo, hi] of a convex function (a convex body's signed distance along a
// segment) by golden-section search; the interval's ends are compared too (the minimum may sit on
// them).
template <typename F>
double minimise_convex(const F& f, double lo = 0.0, double hi = 1.0) {
  constexpr double kInvPhi = 0.6180339887498949;
  const double lo0 = lo, hi0 = hi;
  double x1 = hi - kInvPhi * (hi - lo), x2 = lo + kInvPhi * (hi - lo);
  double f1 = f(x1), f2 = f(x2);
  while (hi - lo > 1e-13) {
    if (f1 <= f2) {
      hi = x2, x2 = x1, f2 = f1;
      x1 = hi - kInvPhi * (hi - lo), f1 = f(x1);
    } else {
      lo = x1, x1 = x2, f1 = f2;
      x2 = lo + kInvPhi * (hi - lo), f2 = f(x2);
    }
  }
  double s = 0.5 * (lo + hi), best = f(s);
  for (double e : {lo0, hi0}) {
    const double fe = f(e);
    if (fe < best) best = fe, s = e;
  }
  return s;
}

struct Entry {
  Obstacle ob;
  Box3 local_box;       // bounds in the obstacle frame (not for planes)
  Box3 world_box;       // local_box's corners in the world
  double extent = 0.0;  // farthest point of local_box from the frame's origin (not for planes)
  double speed = 0.0;   // the largest speed of the surface (planes: along the normal, unturned)
  double spin = 0.0;    // planes: the angular speed (the surface speed grows with the distance)
  std::shared_ptr<fcl::CollisionGeometryd> geom;  // boxes, cylinders, meshes
  std::unique_ptr<fcl::CollisionObjectd> object;
  // Meshes: unit face normals (by winding) and, when the mesh is closed (every edge shared by
  // exactly two triangles after welding equal vertices), angle-weighted pseudo-normals of edges
  // and vertices, whose sign test tells inside from outside (Baerentzen and Aanaes 2005).
  std::vector<Vec3> face_normals;
  bool closed = false;
  std::vector<int> weld;                             // vertex -> welded vertex
  std::map<std::pair<int, int>, Vec3> edge_normals;  // welded (min, max) -> pseudo-normal
  std::vector<Vec3> vertex_normals;                  // welded vertex -> pseudo-normal
};

std::string label(const Obstacle& ob, int index) {
  return ob.name.empty() ? "obstacle #" + std::to_string(index) : "obstacle '" + ob.name + "'";
}

bool finite_pose(const Eigen::Isometry3d& pose) {
  if (!pose.matrix().allFinite()) return false;
  const Eigen::Matrix3d r = pose.linear();
  return (r.transpose() * r - Eigen::Matrix3d::Identity()).norm() < 1e-6 && r.determinant() > 0.0;
}

void refresh_world_box(Entry* e) {
  if (e->ob.shape.kind == ObstacleShape::Kind::kPlane) return;
  e->world_box.setEmpty();
  for (int c = 0; c < 8; ++c) {
    e->world_box.extend(e->ob.pose * e->local_box.corner(static_cast<Box3::CornerType>(c)));
  }
  if (e->object) {
    e->object->setTransform(e->ob.pose);
    e->object->computeAABB();  // setTransform leaves FCL's box stale
  }
}

void prepare_mesh(Entry* e, const std::string& who) {
  const TriangleMesh& m = *e->ob.shape.mesh;
  const int nv = static_cast<int>(m.vertices.size());
  if (m.triangles.empty() || nv < 3) {
    throw std::invalid_argument(who + ": the mesh has no triangles");
  }
  for (const Vec3& v : m.vertices) {
    if (!v.allFinite()) throw std::invalid_argument(who + ": the mesh has a non-finite vertex");
  }
  for (size_t t = 0; t < m.triangles.size(); ++t) {
    const Eigen::Vector3i& tri = m.triangles[t];
    if (tri.minCoeff() < 0 || tri.maxCoeff() >= nv) {
      throw std::invalid_argument(who + ": mesh triangle " + std::to_string(t) +
                                  " has a vertex index out of range (" + std::to_string(nv) +
                                  " vertices)");
    }
  }
  // Welding equal positions: mesh files (STL) repeat vertices per triangle.
  std::map<std::tuple<double, double, double>, int> index;
  e->weld.resize(nv);
  int nw = 0;
  for (int i = 0; i < nv; ++i) {
    const Vec3& v = m.vertices[i];
    auto it = index.emplace(std::make_tuple(v.x(), v.y(), v.z()), nw).first;
    if (it->second == nw) ++nw;
    e->weld[i] = it->second;
  }
  e->vertex_normals.assign(nw, Vec3::Zero());
  std::map<std::pair<int, int>, int> edge_count;
  e->face_normals.resize(m.triangles.size());
  double area = 0.0;
  for (size_t t = 0; t < m.triangles.size(); ++t) {
    const Eigen::Vector3i& tri = m.triangles[t];
    const Vec3 cross =
        (m.vertices[tri[1]] - m.vertices[tri[0]]).cross(m.vertices[tri[2]] - m.vertices[tri[0]]);
    const double len = cross.norm();
    area += 0.5 * len;
    const Vec3 n = len > 0.0 ? Vec3(cross / len) : Vec3::Zero();
    e->face_normals[t] = n;
    for (int k = 0; k < 3; ++k) {
      const int i = e->weld[tri[k]], j = e->weld[tri[(k + 1) % 3]];
      const std::pair<int, int> key(std::min(i, j), std::max(i, j));
      e->edge_normals.emplace(key, Vec3::Zero()).first->second += n;  // Eigen: no zero default
      ++edge_count[key];
      const Vec3 u = m.vertices[tri[(k + 1) % 3]] - m.vertices[tri[k]];
      const Vec3 w = m.vertices[tri[(k + 2) % 3]] - m.vertices[tri[k]];
      const double un = u.norm(), wn = w.norm();
      if (un > 0.0 && wn > 0.0) {
        const double angle = std::acos(std::clamp(u.dot(w) / (un * wn), -1.0, 1.0));
        e->vertex_normals[e->weld[tri[k]]] += angle * n;
      }
    }
  }
  if (!(area > 0.0)) throw std::invalid_argument(who + ": the mesh's triangles have no area");
  e->closed = std::all_of(edge_count.begin(), edge_count.end(),
                          [](const auto& kv) { return kv.second == 2; });

  auto model = std::make_shared<fcl::BVHModel<fcl::OBBRSSd>>();
  model->beginModel(static_cast<int>(m.triangles.size()), nv);
  for (const Eigen::Vector3i& tri : m.triangles) {
    model->addTriangle(m.vertices[tri[0]], m.vertices[tri[1]], m.vertices[tri[2]]);
  }
  model->endModel();
  e->geom = model;
  e->local_box.setEmpty();
  for (const Vec3& v : m.vertices) e->local_box.extend(v);
}

}  // namespace

struct ObstacleSet::Impl {
  std::vector<Entry> entries;
};

ObstacleSet::ObstacleSet() : impl_(new Impl) {}
ObstacleSet::~ObstacleSet() = default;

namespace {

// An obstacle checked and prepared for slot `index`; throws std::invalid_argument naming it.
Entry make_entry(const Obstacle& obstacle, int index) {
  using Kind = ObstacleShape::Kind;
  const std::string who = label(obstacle, index);
  const Vec3& size = obstacle.shape.size;
  auto positive = [&](double v, const char* what) {
    if (!(std::isfinite(v) && v > 0.0)) {
      std::ostringstream msg;
      msg << who << ": " << what << " must be positive and finite (got " << v << ")";
      throw std::invalid_argument(msg.str());
    }
  };
  if (!finite_pose(obstacle.pose)) {
    throw std::invalid_argument(who + ": the pose is not finite or not a rotation");
  }
  if (!(std::isfinite(obstacle.friction) && obstacle.friction >= 0.0)) {
    throw std::invalid_argument(who + ": friction must be finite and non-negative");
  }
  Entry e;
  e.ob = obstacle;
  switch (obstacle.shape.kind) {
    case Kind::kPlane:
      break;
    case Kind::kBox:
      positive(size.x(), "box size x");
      positive(size.y(), "box size y");
      positive(size.z(), "box size z");
      e.geom = std::make_shared<fcl::Boxd>(size);
      e.local_box = Box3(-0.5 * size, 0.5 * size);
      break;
    case Kind::kSphere:
      positive(size.x(), "sphere radius (size x)");
      e.local_box = Box3(-size.x() * Vec3::Ones(), size.x() * Vec3::Ones());
      break;
    case Kind::kCylinder:
      positive(size.x(), "cylinder radius (size x)");
      positive(size.y(), "cylinder length (size y)");
      e.geom = std::make_shared<fcl::Cylinderd>(size.x(), size.y());
      e.local_box = Box3(Vec3(-size.x(), -size.x(), -0.5 * size.y()),
                         Vec3(size.x(), size.x(), 0.5 * size.y()));
      break;
    case Kind::kCapsule:
      positive(size.x(), "capsule radius (size x)");
      if (!(std::isfinite(size.y()) && size.y() >= 0.0)) {
        throw std::invalid_argument(who + ": capsule length (size y) must be finite and >= 0");
      }
      e.local_box = Box3(-Vec3(size.x(), size.x(), size.x() + 0.5 * size.y()),
                         Vec3(size.x(), size.x(), size.x() + 0.5 * size.y()));
      break;
    case Kind::kMesh:
      if (!obstacle.shape.mesh) throw std::invalid_argument(who + ": a mesh obstacle needs a mesh");
      prepare_mesh(&e, who);
      break;
    default:
      throw std::invalid_argument(who + ": unknown shape kind");
  }
  if (obstacle.shape.kind != Kind::kPlane)
    for (int c = 0; c < 8; ++c)
      e.extent = std::max(e.extent, e.local_box.corner(static_cast<Box3::CornerType>(c)).norm());
  if (e.geom) {
    e.geom->computeLocalAABB();
    e.object = std::make_unique<fcl::CollisionObjectd>(e.geom);
  }
  refresh_world_box(&e);
  return e;
}

}  // namespace

int ObstacleSet::add(const Obstacle& obstacle) {
  const int index = size();
  impl_->entries.push_back(make_entry(obstacle, index));
  return index;
}

void ObstacleSet::replace(int i, const Obstacle& obstacle) {
  Entry& slot = impl_->entries.at(i);
  slot = make_entry(obstacle, i);
}

int ObstacleSet::size() const { return static_cast<int>(impl_->entries.size()); }

const Obstacle& ObstacleSet::obstacle(int i) const { return impl_->entries.at(i).ob; }

void ObstacleSet::set_pose(int i, const Eigen::Isometry3d& pose) {
  Entry& e = impl_->entries.at(i);
  if (!finite_pose(pose)) {
    throw std::invalid_argument(label(e.ob, i) + ": the pose is not finite or not a rotation");
  }
  e.ob.pose = pose;
  refresh_world_box(&e);
}

void ObstacleSet::set_pose(int i, const Eigen::Isometry3d& pose, const Vec3& linear_velocity,
                           const Vec3& angular_velocity) {
  Entry& e = impl_->entries.at(i);
  if (!linear_velocity.allFinite() || !angular_velocity.allFinite())
    throw std::invalid_argument(label(e.ob, i) + ": the velocity is not finite");
  set_pose(i, pose);
  e.ob.linear_velocity = linear_velocity;
  e.ob.angular_velocity = angular_velocity;
  // A plane slides along itself without coming closer: only its normal speed counts.
  const bool plane = e.ob.shape.kind == ObstacleShape::Kind::kPlane;
  e.speed = plane ? std::abs(pose.linear().col(2).dot(linear_velocity))
                  : linear_velocity.norm() + angular_velocity.norm() * e.extent;
  e.spin = plane ? angular_velocity.norm() : 0.0;
}

namespace {

// A contact from the axis point p and its analytic local answer (primitive frame).
SegmentContact from_local(const Eigen::Isometry3d& pose, double s, const LocalSdf& l) {
  SegmentContact c;
  c.s = s;
  c.distance = l.d;
  c.on_obstacle = pose * l.q;
  c.normal = pose.linear() * l.n;
  return c;
}

// Box or cylinder: FCL finds the closest pair while the axis is outside; when FCL reports a
// collision (it returns -1 and no points), a distance too small to trust, or throws, the signed
// distance along the axis is minimised analytically instead (both bodies are convex). The local
// answer at FCL's axis point is analytic too, which makes the surface point and normal exact.
template <typename Sdf>
SegmentContact convex_query(const Entry& e, const Vec3& a, const Vec3& b, const Sdf& sdf) {
  const Eigen::Isometry3d inv = e.ob.pose.inverse();
  const Vec3 la = inv * a, lb = inv * b;
  const Vec3 d = b - a;
  const double len = d.norm();
  double s = -1.0;
  if (len > 0.0) {
    // The axis as an FCL capsule of radius 0 (a segment); GJK accepts it. FCL's own GJK: libccd's
    // distances are off by far more than the tolerance in FCL 0.7.
    const fcl::Capsuled axis(0.0, len);
    fcl::Transform3d tf = fcl::Transform3d::Identity();
    tf.linear() = Eigen::Quaterniond::FromTwoVectors(Vec3::UnitZ(), d).toRotationMatrix();
    tf.translation() = 0.5 * (a + b);
    fcl::DistanceRequestd request(true);
    request.gjk_solver_type = fcl::GST_INDEP;
    request.distance_tolerance = kGjkTolerance;
    fcl::DistanceResultd result;
    try {
      const double dist = fcl::distance(e.object->collisionGeometry().get(),
                                        e.object->getTransform(), &axis, tf, request, result);
      // Nearest points are in the world frame in FCL 0.7 (checked by the tests).
      if (dist > 1e-9 * (1.0 + e.local_box.sizes().maxCoeff())) {
        s = closest_s(a, b, result.nearest_points[1]);
      }
    } catch (const std::exception&) {
      s = -1.0;  // GJK can fail near touching: the analytic path below answers
    }
  } else {
    s = 0.0;
  }
  const auto along = [&](double t) { return sdf(la + t * (lb - la)).d; };
  if (s >= 0.0 && len > 0.0) {
    // GJK stops at a tolerance on the distance, which leaves s off by up to its square root near
    // round or flat minima (1e-5 seen): polish s nearby. The signed distance is convex along the
    // axis, so a minimum inside the bracket is the minimum; one on a bracket end that is not an
    // end of the axis means GJK was further off, and the whole axis is searched.
    constexpr double kBracket = 1e-2;
    const double lo = std::max(0.0, s - kBracket), hi = std::min(1.0, s + kBracket);
    s = minimise_convex(along, lo, hi);
    if ((s == lo && lo > 0.0) || (s == hi && hi < 1.0)) s = -1.0;
  }
  if (s < 0.0) s = minimise_convex(along);
  return from_local(e.ob.pose, s, sdf(la + s * (lb - la)));
}

// First triangle the segment crosses, by brute force (the rare case where FCL's collide gives
// no contact although its distance reported an overlap).
bool segment_hits_triangle(const Vec3& a, const Vec3& b, const Vec3& v0, const Vec3& v1,
                           const Vec3& v2, double* s) {
  const Vec3 d = b - a, e1 = v1 - v0, e2 = v2 - v0;
  const Vec3 p = d.cross(e2);
  const double det = e1.dot(p);
  const double scale = e1.norm() * e2.norm() * d.norm();
  if (std::abs(det) <= 1e-12 * scale) return false;
  const Vec3 t = a - v0;
  const double u = t.dot(p) / det;
  const Vec3 q = t.cross(e1);
  const double v = d.dot(q) / det;
  const double w = e2.dot(q) / det;
  constexpr double kTol = 1e-9;
  if (u < -kTol || v < -kTol || u + v > 1.0 + kTol || w < -kTol || w > 1.0 + kTol) return false;
  *s = std::clamp(w, 0.0, 1.0);
  return true;
}

// Mesh. FCL's mesh-shape distance skips the triangles the axis crosses (their GJK reports a
// collision and no distance), so a crossing is looked for first with FCL's collide: the crossed
// triangle, the crossing point (exact, computed here) and distance 0 with that triangle's normal
// (by winding): FCL gives meshes no penetration depth. Otherwise FCL's distance gives the closest
// pair; if the mesh is closed, the pseudo-normal of the closest feature tells whether the axis is
// inside (then the distance is negative and the normal points out).
SegmentContact mesh_query(const Entry& e, const Vec3& a, const Vec3& b) {
  const TriangleMesh& m = *e.ob.shape.mesh;
  const Vec3 d = b - a;
  const double len = d.norm();
  const fcl::Capsuled axis(0.0, len);
  fcl::Transform3d tf = fcl::Transform3d::Identity();
  if (len > 0.0) {
    tf.linear() = Eigen::Quaterniond::FromTwoVectors(Vec3::UnitZ(), d).toRotationMatrix();
  }
  tf.translation() = 0.5 * (a + b);
  const fcl::CollisionGeometryd* geom = e.object->collisionGeometry().get();
  const Eigen::Isometry3d& pose = e.ob.pose;
  const Eigen::Isometry3d inv = pose.inverse();
  const Vec3 la = inv * a, lb = inv * b;
  SegmentContact c;

  auto crossing = [&](int tri_id, const Vec3& near) {
    const Eigen::Vector3i& tri = m.triangles[tri_id];
    double st;
    c.s = segment_hits_triangle(la, lb, m.vertices[tri[0]], m.vertices[tri[1]], m.vertices[tri[2]],
                                &st)
              ? st
              : closest_s(a, b, near);
    c.distance = 0.0;
    c.on_obstacle = a + c.s * d;
    c.normal = pose.linear() * e.face_normals[tri_id];
    return c;
  };

  if (len > 0.0) {
    try {
      fcl::CollisionRequestd request(1, true);
      request.gjk_solver_type = fcl::GST_INDEP;
      fcl::CollisionResultd cres;
      if (fcl::collide(geom, e.object->getTransform(), &axis, tf, request, cres) > 0) {
        const auto& contact = cres.getContact(0);
        if (contact.b1 >= 0 && contact.b1 < static_cast<intptr_t>(m.triangles.size())) {
          return crossing(static_cast<int>(contact.b1), contact.pos);
        }
      }
    } catch (const std::exception&) {
      // GJK/EPA can fail near touching: the distance below or the scan answers
    }
  }
  double dist = -1.0;
  fcl::DistanceResultd result;
  try {
    fcl::DistanceRequestd request(true);
    request.gjk_solver_type = fcl::GST_INDEP;
    request.distance_tolerance = kGjkTolerance;
    dist = fcl::distance(geom, e.object->getTransform(), &axis, tf, request, result);
  } catch (const std::exception&) {
    dist = -1.0;
  }
  if (dist > 1e-12 && result.b1 >= 0 && result.b1 < static_cast<intptr_t>(m.triangles.size())) {
    const Vec3 q = result.nearest_points[0], p = result.nearest_points[1];
    c.s = closest_s(a, b, p);
    c.on_obstacle = q;
    c.distance = (p - q).norm();
    c.normal = (p - q) / c.distance;
    if (e.closed) {
      // The closest feature of triangle b1: face, edge or vertex, by barycentric coordinates.
      const Eigen::Vector3i& tri = m.triangles[result.b1];
      const Vec3 lq = inv * q;
      const Vec3 v0 = m.vertices[tri[0]], e1 = m.vertices[tri[1]] - v0,
                 e2 = m.vertices[tri[2]] - v0;
      const double d00 = e1.dot(e1), d01 = e1.dot(e2), d11 = e2.dot(e2);
      const double d20 = (lq - v0).dot(e1), d21 = (lq - v0).dot(e2);
      const double den = d00 * d11 - d01 * d01;
      const double w1 = (d11 * d20 - d01 * d21) / den, w2 = (d00 * d21 - d01 * d20) / den;
      const double bary[3] = {1.0 - w1 - w2, w1, w2};
      constexpr double kEdge = 1e-7;  // GJK's points are that close to the true feature
      int zero[3], nz = 0;
      for (int k = 0; k < 3; ++k) {
        if (bary[k] < kEdge) zero[nz++] = k;
      }
      Vec3 pseudo = e.face_normals[result.b1];
      if (nz == 1) {
        const int i = e.weld[tri[(zero[0] + 1) % 3]], j = e.weld[tri[(zero[0] + 2) % 3]];
        pseudo = e.edge_normals.at({std::min(i, j), std::max(i, j)});
      } else if (nz >= 2) {
        pseudo = e.vertex_normals[e.weld[tri[3 - zero[0] - zero[1]]]];
      }
      if ((pose.linear() * pseudo).dot(p - q) < 0.0) {
        c.distance = -c.distance;
        c.normal = -c.normal;
      }
    }
    return c;
  }
  // Touching within tolerances, or a degenerate axis on the surface: the first triangle crossed,
  // else the closest one's plane.
  for (size_t t = 0; t < m.triangles.size(); ++t) {
    const Eigen::Vector3i& tri = m.triangles[t];
    double st;
    if (segment_hits_triangle(la, lb, m.vertices[tri[0]], m.vertices[tri[1]], m.vertices[tri[2]],
                              &st)) {
      return crossing(static_cast<int>(t), a + st * d);
    }
  }
  const int tri_id = result.b1 >= 0 && result.b1 < static_cast<intptr_t>(m.triangles.size())
                         ? static_cast<int>(result.b1)
                         : 0;
  return crossing(tri_id, result.nearest_points[1]);
}

}  // namespace

void ObstacleSet::query(const Vec3& a, const Vec3& b, double rod_reach,
                        std::vector<SegmentContact>* out, std::vector<int>* which, double h) const {
  using Kind = ObstacleShape::Kind;
  const Box3 seg_box = Box3(a.cwiseMin(b), a.cwiseMax(b));
  for (size_t i = 0; i < impl_->entries.size(); ++i) {
    const Entry& e = impl_->entries[i];
    if (!e.ob.enabled) continue;
    const Eigen::Isometry3d& pose = e.ob.pose;
    const Vec3& size = e.ob.shape.size;
    double reach = rod_reach;
    if (h > 0.0 && (e.speed > 0.0 || e.spin > 0.0)) {
      const double arm =
          e.spin > 0.0 ? std::max((a - pose.translation()).norm(), (b - pose.translation()).norm())
                       : 0.0;
      reach += h * (e.speed + e.spin * arm);
    }
    SegmentContact c;
    if (e.ob.shape.kind == Kind::kPlane) {
      // Signed heights of the end points; the lower one is closest (or deepest). A segment
      // parallel to the plane touches along its length: its middle stands for it.
      const Vec3 n = pose.linear().col(2);
      const double da = n.dot(a - pose.translation()), db = n.dot(b - pose.translation());
      if (std::min(da, db) > reach) continue;
      c.s = da < db ? 0.0 : (db < da ? 1.0 : 0.5);
      c.distance = std::min(da, db);
      c.normal = n;
      c.on_obstacle = a + c.s * (b - a) - c.distance * n;
    } else {
      // Own bounding boxes: FCL's box of a rotated object is a loose cube.
      Box3 grown = e.world_box;
      grown.min().array() -= reach;
      grown.max().array() += reach;
      if (!grown.intersects(seg_box)) continue;
      switch (e.ob.shape.kind) {
        case Kind::kSphere: {
          const Vec3 centre = pose.translation();
          c.s = closest_s(a, b, centre);
          const Vec3 p = a + c.s * (b - a);
          const double r = (p - centre).norm();
          c.normal = r > 0.0 ? Vec3((p - centre) / r) : Vec3(pose.linear().col(2));
          c.distance = r - size.x();
          c.on_obstacle = centre + size.x() * c.normal;
          break;
        }
        case Kind::kCapsule: {
          const Vec3 half = 0.5 * size.y() * pose.linear().col(2);
          const Vec3 q0 = pose.translation() - half, q1 = pose.translation() + half;
          double t;
          segment_segment(a, b, q0, q1, &c.s, &t);
          const Vec3 p = a + c.s * (b - a), q = q0 + t * (q1 - q0);
          const double r = (p - q).norm();
          if (r > 0.0) {
            c.normal = (p - q) / r;
          } else {
            // The axes cross: any direction normal to the capsule's axis (and the segment's).
            Vec3 n = (b - a).cross(q1 - q0);
            if (n.norm() == 0.0) n = pose.linear().col(0);
            c.normal = n.normalized();
          }
          c.distance = r - size.x();
          c.on_obstacle = q + size.x() * c.normal;
          break;
        }
        case Kind::kBox: {
          const Vec3 h = 0.5 * size;
          c = convex_query(e, a, b, [&h](const Vec3& p) { return box_sdf(p, h); });
          break;
        }
        case Kind::kCylinder: {
          const double rad = size.x(), hl = 0.5 * size.y();
          c = convex_query(e, a, b, [=](const Vec3& p) { return cylinder_sdf(p, rad, hl); });
          break;
        }
        case Kind::kMesh:
          c = mesh_query(e, a, b);
          break;
        default:
          continue;
      }
      if (c.distance > reach) continue;
    }
    out->push_back(c);
    if (which) which->push_back(static_cast<int>(i));
  }
}

}  // namespace corde
