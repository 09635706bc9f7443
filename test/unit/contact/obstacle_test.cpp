// Obstacle queries against independent references: each primitive's signed distance of a point
// (written here again), minimised over densely sampled axis points, at random poses with the axis
// outside, touching and inside.
#include "corde_sim/contact/obstacle.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

namespace corde {
namespace {

using Kind = ObstacleShape::Kind;

Eigen::Isometry3d random_pose(std::mt19937* rng, double spread) {
  std::normal_distribution<double> n(0.0, 1.0);
  Eigen::Quaterniond q(n(*rng), n(*rng), n(*rng), n(*rng));
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = q.normalized().toRotationMatrix();
  t.translation() = spread * Vec3(n(*rng), n(*rng), n(*rng));
  return t;
}

// Reference signed distances of a point in the obstacle's frame.
double ref_sdf(const ObstacleShape& s, const Vec3& p) {
  switch (s.kind) {
    case Kind::kPlane:
      return p.z();
    case Kind::kSphere:
      return p.norm() - s.size.x();
    case Kind::kCapsule: {
      const double hl = 0.5 * s.size.y();
      const Vec3 q(0.0, 0.0, std::clamp(p.z(), -hl, hl));
      return (p - q).norm() - s.size.x();
    }
    case Kind::kBox: {
      const Vec3 h = 0.5 * s.size;
      const Vec3 d = p.cwiseAbs() - h;
      return d.cwiseMax(0.0).norm() + std::min(d.maxCoeff(), 0.0);
    }
    case Kind::kCylinder: {
      const double dr = std::hypot(p.x(), p.y()) - s.size.x();
      const double dz = std::abs(p.z()) - 0.5 * s.size.y();
      return std::hypot(std::max(dr, 0.0), std::max(dz, 0.0)) + std::min(std::max(dr, dz), 0.0);
    }
    default:
      return 0.0;
  }
}

// Minimum of the reference over 20001 axis points.
double ref_min(const Obstacle& ob, const Vec3& a, const Vec3& b) {
  const Eigen::Isometry3d inv = ob.pose.inverse();
  double best = 1e300;
  for (int k = 0; k <= 20000; ++k) {
    best = std::min(best, ref_sdf(ob.shape, inv * (a + (k / 20000.0) * (b - a))));
  }
  return best;
}

Obstacle make(Kind kind, const Vec3& size, const std::string& name = "ob") {
  Obstacle ob;
  ob.name = name;
  ob.shape.kind = kind;
  ob.shape.size = size;
  return ob;
}

SegmentContact query_one(const ObstacleSet& set, const Vec3& a, const Vec3& b, double reach = 1e9) {
  std::vector<SegmentContact> out;
  std::vector<int> which;
  set.query(a, b, reach, &out, &which);
  EXPECT_EQ(out.size(), 1u);
  EXPECT_EQ(which.size(), out.size());
  return out.empty() ? SegmentContact{} : out[0];
}

// The contact is consistent: unit normal, the surface point on the surface, the axis point at
// the signed distance along the normal from it, and no sampled axis point deeper than reported.
void check_contact(const Obstacle& ob, const Vec3& a, const Vec3& b, const SegmentContact& c,
                   double tol, const std::string& what) {
  SCOPED_TRACE(what);
  const Eigen::Isometry3d inv = ob.pose.inverse();
  const Vec3 p = a + c.s * (b - a);
  EXPECT_GE(c.s, 0.0);
  EXPECT_LE(c.s, 1.0);
  EXPECT_NEAR(c.normal.norm(), 1.0, 1e-9);
  EXPECT_NEAR(ref_sdf(ob.shape, inv * c.on_obstacle), 0.0, 1e-9);
  EXPECT_NEAR(ref_sdf(ob.shape, inv * p), c.distance, 1e-9);
  EXPECT_LT((c.on_obstacle + c.distance * c.normal - p).norm(), 1e-9);
  const double ref = ref_min(ob, a, b);
  EXPECT_LE(c.distance, ref + 1e-9) << c.distance - ref;
  EXPECT_GE(c.distance, ref - tol);
}

void random_cases(Kind kind, const Vec3& size) {
  std::mt19937 rng(static_cast<unsigned>(kind) * 7919u + 1u);
  std::normal_distribution<double> n(0.0, 1.0);
  int outside = 0, inside = 0, crossing = 0;
  for (int trial = 0; trial < 300; ++trial) {
    Obstacle ob = make(kind, size);
    ob.pose = random_pose(&rng, 2.0);
    ObstacleSet set;
    set.add(ob);
    // End points spread from very near the obstacle's centre (inside) to well outside.
    const double spread = trial % 3 == 0 ? 0.1 : (trial % 3 == 1 ? 0.6 : 2.0);
    const Vec3 a = ob.pose * Vec3(spread * Vec3(n(rng), n(rng), n(rng)));
    const Vec3 b = ob.pose * Vec3(spread * Vec3(n(rng), n(rng), n(rng)));
    const SegmentContact c = query_one(set, a, b);
    const double inv_a = ref_sdf(ob.shape, ob.pose.inverse() * a);
    const double inv_b = ref_sdf(ob.shape, ob.pose.inverse() * b);
    if (c.distance > 0.0) ++outside;
    if (inv_a < 0.0 && inv_b < 0.0) ++inside;
    if (c.distance < 0.0 && (inv_a > 0.0 || inv_b > 0.0)) ++crossing;
    // The sampled reference is coarse by up to half a sample step times the slope (1).
    check_contact(ob, a, b, c, 1e-4 * (b - a).norm() + 1e-9, "trial " + std::to_string(trial));
  }
  EXPECT_GT(outside, 30);
  EXPECT_GT(inside, 10);
  EXPECT_GT(crossing, 10);
}

TEST(Obstacle, BoxAtRandomPoses) { random_cases(Kind::kBox, Vec3(0.8, 0.5, 1.2)); }
TEST(Obstacle, CylinderAtRandomPoses) { random_cases(Kind::kCylinder, Vec3(0.4, 1.0, 0.0)); }
TEST(Obstacle, SphereAtRandomPoses) { random_cases(Kind::kSphere, Vec3(0.5, 0.0, 0.0)); }
TEST(Obstacle, CapsuleAtRandomPoses) { random_cases(Kind::kCapsule, Vec3(0.3, 0.8, 0.0)); }

TEST(Obstacle, TouchingSegments) {
  // Axes lying on a face, along an edge, through a corner: distance 0 with the face's normal.
  ObstacleSet set;
  Obstacle box = make(Kind::kBox, Vec3(2.0, 2.0, 2.0), "box");
  box.pose.translation() = Vec3(1.0, 2.0, 3.0);
  set.add(box);
  const Vec3 c = box.pose.translation();
  SegmentContact on_face = query_one(set, c + Vec3(-0.5, 0.2, 1.0), c + Vec3(0.5, -0.3, 1.0));
  EXPECT_NEAR(on_face.distance, 0.0, 1e-12);
  EXPECT_LT((on_face.normal - Vec3::UnitZ()).norm(), 1e-12);
  SegmentContact on_edge = query_one(set, c + Vec3(-3.0, 1.0, 1.0), c + Vec3(3.0, 1.0, 1.0));
  EXPECT_NEAR(on_edge.distance, 0.0, 1e-12);
  SegmentContact corner = query_one(set, c + Vec3(1.0, 1.0, 1.0), c + Vec3(2.0, 2.0, 2.0));
  EXPECT_NEAR(corner.distance, 0.0, 1e-12);
  EXPECT_NEAR(corner.s, 0.0, 1e-12);

  ObstacleSet cyl_set;
  Obstacle cyl = make(Kind::kCylinder, Vec3(0.5, 2.0, 0.0), "cyl");
  cyl_set.add(cyl);
  SegmentContact side = query_one(cyl_set, Vec3(0.5, -1.0, 0.3), Vec3(0.5, 1.0, 0.3));
  EXPECT_NEAR(side.distance, 0.0, 1e-12);
  EXPECT_LT((side.normal - Vec3::UnitX()).norm(), 1e-6);  // tangent: s found to ~1e-8
  EXPECT_NEAR(side.s, 0.5, 1e-6);
  // A segment ending on the cap's rim from outside.
  SegmentContact rim = query_one(cyl_set, Vec3(0.5, 0.0, 1.0), Vec3(1.5, 0.0, 2.0));
  EXPECT_NEAR(rim.distance, 0.0, 1e-12);
}

TEST(Obstacle, AxisInsidePrimitives) {
  // Deepest axis point and depth by hand.
  ObstacleSet set;
  set.add(make(Kind::kBox, Vec3(2.0, 4.0, 6.0), "box"));
  const SegmentContact c = query_one(set, Vec3(-2.0, 0.0, 0.0), Vec3(2.0, 0.0, 0.0));
  EXPECT_NEAR(c.distance, -1.0, 1e-9);  // the x faces are 1 away from the centre
  EXPECT_NEAR(c.s, 0.5, 1e-6);
  EXPECT_NEAR(std::abs(c.normal.x()), 1.0, 1e-9);

  ObstacleSet cyl;
  cyl.add(make(Kind::kCylinder, Vec3(1.0, 0.5, 0.0), "cyl"));
  const SegmentContact d = query_one(cyl, Vec3(0.2, 0.0, -0.1), Vec3(0.2, 0.0, 0.1));
  EXPECT_NEAR(d.distance, -0.25, 1e-9);  // nearer the caps (0.25 at z = 0) than the side (0.8)
  EXPECT_NEAR(d.s, 0.5, 1e-6);
  EXPECT_NEAR(std::abs(d.normal.z()), 1.0, 1e-9);
}

TEST(Obstacle, Plane) {
  ObstacleSet set;
  Obstacle floor = make(Kind::kPlane, Vec3::Zero(), "floor");
  floor.pose.linear() = Eigen::AngleAxisd(0.3, Vec3::UnitX()).toRotationMatrix();
  floor.pose.translation() = Vec3(0.0, 0.0, -1.0);
  set.add(floor);
  const Vec3 n = floor.pose.linear().col(2);
  const Vec3 o = floor.pose.translation();
  const Vec3 a = o + 0.7 * n + Vec3(0.3, 0.1, 0.0), b = o - 0.2 * n + Vec3(-1.0, 0.4, 0.0);
  const SegmentContact c = query_one(set, a, b);
  EXPECT_NEAR(c.distance, n.dot(b - o), 1e-12);
  EXPECT_EQ(c.s, 1.0);
  EXPECT_LT((c.normal - n).norm(), 1e-12);
  EXPECT_NEAR(n.dot(c.on_obstacle - o), 0.0, 1e-12);
  EXPECT_LT((c.on_obstacle + c.distance * c.normal - b).norm(), 1e-12);
  // Parallel: the middle.
  const SegmentContact p = query_one(set, o + 0.5 * n, o + 0.5 * n + Vec3::UnitX());
  EXPECT_NEAR(p.distance, 0.5, 1e-12);
  EXPECT_EQ(p.s, 0.5);
  // Beyond reach: nothing.
  std::vector<SegmentContact> out;
  set.query(o + 2.0 * n, o + 3.0 * n, 1.0, &out, nullptr);
  EXPECT_TRUE(out.empty());
}

// A closed cube as 12 outward-wound triangles, vertices shared or repeated per triangle.
std::shared_ptr<TriangleMesh> cube_mesh(const Vec3& size, bool welded) {
  auto m = std::make_shared<TriangleMesh>();
  const Vec3 h = 0.5 * size;
  std::vector<Vec3> corners;
  for (int i = 0; i < 8; ++i) {
    corners.emplace_back(i & 1 ? h.x() : -h.x(), i & 2 ? h.y() : -h.y(), i & 4 ? h.z() : -h.z());
  }
  // Faces as quads (outward, counter-clockwise seen from outside).
  const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                           {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  auto vertex = [&](int corner) {
    if (welded) return corner;
    m->vertices.push_back(corners[corner]);
    return static_cast<int>(m->vertices.size()) - 1;
  };
  if (welded) m->vertices = corners;
  for (const auto& q : quads) {
    m->triangles.emplace_back(vertex(q[0]), vertex(q[1]), vertex(q[2]));
    m->triangles.emplace_back(vertex(q[0]), vertex(q[2]), vertex(q[3]));
  }
  return m;
}

TEST(Obstacle, MeshCubeMatchesBox) {
  std::mt19937 rng(42);
  std::normal_distribution<double> n(0.0, 1.0);
  const Vec3 size(0.8, 0.5, 1.2);
  int inside = 0;
  for (int trial = 0; trial < 200; ++trial) {
    Obstacle box = make(Kind::kBox, size, "box");
    box.pose = random_pose(&rng, 2.0);
    Obstacle mesh = box;
    mesh.name = "mesh";
    mesh.shape.kind = Kind::kMesh;
    mesh.shape.size = Vec3::Zero();
    mesh.shape.mesh = cube_mesh(size, trial % 2 == 0);
    ObstacleSet boxes, meshes;
    boxes.add(box);
    meshes.add(mesh);
    const double spread = trial % 4 == 0 ? 0.1 : 1.5;
    const Vec3 a = box.pose * Vec3(spread * Vec3(n(rng), n(rng), n(rng)));
    const Vec3 b = box.pose * Vec3(spread * Vec3(n(rng), n(rng), n(rng)));
    const SegmentContact cb = query_one(boxes, a, b), cm = query_one(meshes, a, b);
    SCOPED_TRACE("trial " + std::to_string(trial));
    const Vec3 pm = a + cm.s * (b - a);
    EXPECT_NEAR(cm.normal.norm(), 1.0, 1e-9);
    if (cb.distance > 1e-6) {
      // Outside: the same distance; the same closest points unless the closest pair is not
      // unique (a segment parallel to a face), so compare the distance and the consistency.
      EXPECT_NEAR(cm.distance, cb.distance, 1e-7);
      EXPECT_LT((cm.on_obstacle + cm.distance * cm.normal - pm).norm(), 1e-7);
      EXPECT_NEAR(ref_sdf(box.shape, box.pose.inverse() * cm.on_obstacle), 0.0, 1e-7);
    } else {
      const Vec3 la = box.pose.inverse() * a, lb = box.pose.inverse() * b;
      if (ref_sdf(box.shape, la) < 0.0 && ref_sdf(box.shape, lb) < 0.0) {
        // Axis inside the closed mesh: the distance to its surface, negative, normal outward.
        ++inside;
        EXPECT_LT(cm.distance, 0.0);
        EXPECT_NEAR(cm.distance, ref_sdf(box.shape, box.pose.inverse() * pm), 1e-7);
        EXPECT_GE(cm.distance, cb.distance - 1e-9);
        EXPECT_LT((cm.on_obstacle + cm.distance * cm.normal - pm).norm(), 1e-7);
      } else {
        // Crossing the surface: distance 0 at a crossing point, the crossed face's normal.
        EXPECT_EQ(cm.distance, 0.0);
        EXPECT_NEAR(ref_sdf(box.shape, box.pose.inverse() * pm), 0.0, 1e-7);
        const Vec3 ln = box.pose.linear().transpose() * cm.normal;
        EXPECT_NEAR(ln.cwiseAbs().maxCoeff(), 1.0, 1e-9);
      }
    }
  }
  EXPECT_GT(inside, 5);
}

TEST(Obstacle, BoundingBoxPrefilter) {
  ObstacleSet set;
  Obstacle box = make(Kind::kBox, Vec3(0.02, 0.02, 2.0), "pole");
  box.pose.linear() = Eigen::AngleAxisd(0.7, Vec3(1.0, 1.0, 0.0).normalized()).matrix();
  set.add(box);
  set.add(make(Kind::kSphere, Vec3(0.1, 0.0, 0.0), "ball"));
  Obstacle mesh = make(Kind::kMesh, Vec3::Zero(), "cube");
  mesh.shape.mesh = cube_mesh(Vec3::Ones(), true);
  mesh.pose.translation() = Vec3(5.0, 0.0, 0.0);
  set.add(mesh);
  std::vector<SegmentContact> out;
  std::vector<int> which;
  set.query(Vec3(20.0, 20.0, 20.0), Vec3(21.0, 20.0, 20.0), 0.5, &out, &which);
  EXPECT_TRUE(out.empty());
  EXPECT_TRUE(which.empty());
  // Within reach of the cube only.
  set.query(Vec3(5.0, 0.0, 0.8), Vec3(6.0, 0.0, 0.8), 0.5, &out, &which);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(which[0], 2);
  EXPECT_NEAR(out[0].distance, 0.3, 1e-9);
  // Inside the boxes' bounds but beyond reach of the surfaces: nothing.
  out.clear();
  which.clear();
  set.query(Vec3(0.5, -0.5, 0.0), Vec3(0.5, -0.5, 0.1), 0.05, &out, &which);
  EXPECT_TRUE(out.empty());
}

TEST(Obstacle, SetPoseRefreshes) {
  ObstacleSet set;
  Obstacle box = make(Kind::kBox, Vec3(1.0, 1.0, 1.0), "box");
  set.add(box);
  Obstacle mesh = make(Kind::kMesh, Vec3::Zero(), "mesh");
  mesh.shape.mesh = cube_mesh(Vec3::Ones(), false);
  mesh.pose.translation() = Vec3(0.0, 10.0, 0.0);
  set.add(mesh);
  const Vec3 a(3.0, -1.0, 0.0), b(3.0, 1.0, 0.0);
  std::vector<SegmentContact> out;
  std::vector<int> which;
  set.query(a, b, 1.0, &out, &which);
  EXPECT_TRUE(out.empty());
  Eigen::Isometry3d moved = Eigen::Isometry3d::Identity();
  moved.translation() = Vec3(2.0, 0.0, 0.0);
  moved.linear() = Eigen::AngleAxisd(M_PI / 4, Vec3::UnitZ()).matrix();
  set.set_pose(0, moved);
  set.set_pose(1, moved * Eigen::Translation3d(0.0, 0.0, 0.0));
  EXPECT_TRUE(set.obstacle(0).pose.isApprox(moved));
  set.query(a, b, 1.0, &out, &which);
  ASSERT_EQ(out.size(), 2u);
  for (const SegmentContact& c : out) {
    EXPECT_NEAR(c.distance, 1.0 - std::sqrt(0.5), 1e-9);  // the rotated cube's edge at x = 2.707
    EXPECT_NEAR(c.s, 0.5, 1e-6);
    EXPECT_LT((c.normal - Vec3::UnitX()).norm(), 1e-6);
  }
  EXPECT_THROW(set.set_pose(5, moved), std::out_of_range);
  Eigen::Isometry3d bad = moved;
  bad.translation().x() = NAN;
  EXPECT_THROW(set.set_pose(0, bad), std::invalid_argument);
}

void expect_refused(const Obstacle& ob, const std::string& fragment) {
  ObstacleSet set;
  try {
    set.add(ob);
    ADD_FAILURE() << "accepted: " << fragment;
  } catch (const std::invalid_argument& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("'" + ob.name + "'"), std::string::npos) << msg;
    EXPECT_NE(msg.find(fragment), std::string::npos) << msg;
  }
}

TEST(Obstacle, BadShapesRefused) {
  expect_refused(make(Kind::kBox, Vec3(1.0, 0.0, 1.0), "flat box"), "box size y");
  expect_refused(make(Kind::kBox, Vec3(1.0, 1.0, -1.0), "negative box"), "box size z");
  expect_refused(make(Kind::kSphere, Vec3(NAN, 0.0, 0.0), "nan sphere"), "sphere radius");
  expect_refused(make(Kind::kCylinder, Vec3(1.0, 0.0, 0.0), "disc"), "cylinder length");
  expect_refused(make(Kind::kCapsule, Vec3(0.0, 1.0, 0.0), "needle"), "capsule radius");
  expect_refused(make(Kind::kMesh, Vec3::Zero(), "no mesh"), "needs a mesh");
  Obstacle empty = make(Kind::kMesh, Vec3::Zero(), "empty mesh");
  empty.shape.mesh = std::make_shared<TriangleMesh>();
  expect_refused(empty, "no triangles");
  Obstacle out_of_range = make(Kind::kMesh, Vec3::Zero(), "broken mesh");
  auto m = cube_mesh(Vec3::Ones(), true);
  m->triangles[3] = Eigen::Vector3i(0, 1, 8);
  out_of_range.shape.mesh = m;
  expect_refused(out_of_range, "triangle 3");
  Obstacle skewed = make(Kind::kBox, Vec3::Ones(), "skewed");
  skewed.pose.linear() << 1.0, 0.5, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0;
  expect_refused(skewed, "not a rotation");
  Obstacle slippery = make(Kind::kBox, Vec3::Ones(), "slippery");
  slippery.friction = -0.1;
  expect_refused(slippery, "friction");
}

TEST(Obstacle, DegenerateSegment) {
  // A zero-length axis is a point.
  ObstacleSet set;
  set.add(make(Kind::kBox, Vec3(1.0, 1.0, 1.0), "box"));
  set.add(make(Kind::kCylinder, Vec3(0.5, 1.0, 0.0), "cyl"));
  Obstacle mesh = make(Kind::kMesh, Vec3::Zero(), "mesh");
  mesh.shape.mesh = cube_mesh(Vec3::Ones(), true);
  set.add(mesh);
  std::vector<SegmentContact> out;
  std::vector<int> which;
  set.query(Vec3(1.5, 0.0, 0.0), Vec3(1.5, 0.0, 0.0), 2.0, &out, &which);
  ASSERT_EQ(out.size(), 3u);
  EXPECT_NEAR(out[0].distance, 1.0, 1e-9);
  EXPECT_NEAR(out[1].distance, 1.0, 1e-9);
  EXPECT_NEAR(out[2].distance, 1.0, 1e-9);
}

// Run-time changes: replace() keeps every other index, a disabled obstacle is found by no
// query, and a refused replacement leaves the slot as it was.
TEST(Obstacle, ReplaceAndDisableKeepIndices) {
  ObstacleSet set;
  Obstacle a, b;
  a.name = "a";
  a.shape.kind = ObstacleShape::Kind::kSphere;
  a.shape.size.x() = 0.1;
  b = a;
  b.name = "b";
  b.pose.translation() = Vec3(1.0, 0.0, 0.0);
  set.add(a);
  set.add(b);
  std::vector<SegmentContact> found;
  std::vector<int> which;
  const Vec3 p0(0.0, -1.0, 0.15), p1(0.0, 1.0, 0.15);  // 5 cm above sphere a
  set.query(p0, p1, 0.1, &found, &which);
  ASSERT_EQ(which, std::vector<int>{0});
  Obstacle off = a;
  off.enabled = false;
  set.replace(0, off);
  found.clear();
  which.clear();
  set.query(p0, p1, 0.1, &found, &which);
  EXPECT_TRUE(which.empty());
  Obstacle bad = a;
  bad.shape.size.x() = -1.0;
  EXPECT_THROW(set.replace(0, bad), std::invalid_argument);
  EXPECT_FALSE(set.obstacle(0).enabled);
  a.pose.translation() = Vec3(0.0, 0.0, 0.1);  // moved up: the segment now passes inside
  set.replace(0, a);
  found.clear();
  which.clear();
  set.query(p0, p1, 0.1, &found, &which);
  ASSERT_EQ(which, std::vector<int>{0});
  EXPECT_LT(found[0].distance, 0.0);
  EXPECT_EQ(set.obstacle(1).name, "b");
  EXPECT_THROW(set.replace(2, a), std::out_of_range);
}

}  // namespace
}  // namespace corde
