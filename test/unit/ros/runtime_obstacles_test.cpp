// Run-time obstacles: the adapter's ROS-free part (a request's shape turned into an obstacle with
// its checks, the set's stable slots, a frame followed).
#ifdef CORDE_TEST_ROS_ADAPTER
#include "corde_sim/ros/runtime_obstacles.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace corde_sim {
namespace {

using Kind = corde::ObstacleShape::Kind;

ObstacleRequest box_request(const std::string& name) {
  ObstacleRequest r;
  r.name = name;
  r.position = {0.1, 0.2, 0.3};
  r.primitive_type = kBox;
  r.dimensions = {0.4, 0.5, 0.6};
  return r;
}

// The message of the std::invalid_argument `f` throws ("" if none).
template <typename F>
std::string error_of(F f) {
  try {
    f();
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

bool contains(const std::string& s, const std::string& part) {
  return s.find(part) != std::string::npos;
}

TEST(RuntimeObstacleShape, PrimitivesAsShapeMsgsOrdersThem) {
  corde::Obstacle box = obstacle_from_request(box_request("b"));
  EXPECT_EQ(box.shape.kind, Kind::kBox);
  EXPECT_EQ(box.shape.size, corde::Vec3(0.4, 0.5, 0.6));
  EXPECT_EQ(box.pose.translation(), corde::Vec3(0.1, 0.2, 0.3));

  ObstacleRequest c = box_request("c");
  c.primitive_type = kCylinder;
  c.dimensions = {0.8, 0.1};  // shape_msgs: height, radius
  corde::Obstacle cyl = obstacle_from_request(c);
  EXPECT_EQ(cyl.shape.kind, Kind::kCylinder);
  EXPECT_DOUBLE_EQ(cyl.shape.size.x(), 0.1);  // radius
  EXPECT_DOUBLE_EQ(cyl.shape.size.y(), 0.8);  // length along z

  ObstacleRequest s = box_request("s");
  s.primitive_type = kSphere;
  s.dimensions = {0.25};
  EXPECT_DOUBLE_EQ(obstacle_from_request(s).shape.size.x(), 0.25);
}

TEST(RuntimeObstacleShape, PlaneFromCoefficients) {
  ObstacleRequest r = box_request("floor");
  r.primitive_type = kNoPrimitive;
  r.dimensions.clear();
  r.position.setZero();
  r.plane = {0.0, 0.0, 2.0, -1.0};  // 2 z - 1 = 0: z = 0.5, free above
  corde::Obstacle p = obstacle_from_request(r);
  EXPECT_EQ(p.shape.kind, Kind::kPlane);
  EXPECT_NEAR(p.pose.translation().z(), 0.5, 1e-15);
  EXPECT_NEAR(p.pose.linear().col(2).z(), 1.0, 1e-15);
}

TEST(RuntimeObstacleShape, MeshKeepsItsTriangles) {
  ObstacleRequest r = box_request("tri");
  r.primitive_type = kNoPrimitive;
  r.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  r.triangles = {{0, 1, 2}};
  corde::Obstacle m = obstacle_from_request(r);
  ASSERT_EQ(m.shape.kind, Kind::kMesh);
  ASSERT_TRUE(m.shape.mesh);
  EXPECT_EQ(m.shape.mesh->triangles.size(), 1u);
  EXPECT_EQ(m.shape.mesh->vertices[1], corde::Vec3(1, 0, 0));
}

TEST(RuntimeObstacleShape, BadRequestsNameTheField) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  auto bad = [](ObstacleRequest r) { return error_of([&] { obstacle_from_request(r); }); };
  ObstacleRequest r = box_request("b");
  r.position.x() = nan;
  EXPECT_TRUE(contains(bad(r), "position is not finite")) << bad(r);
  r = box_request("b");
  r.orientation = Eigen::Quaterniond(2.0, 0.0, 0.0, 0.0);
  EXPECT_TRUE(contains(bad(r), "not a unit quaternion")) << bad(r);
  r = box_request("b");
  r.dimensions[1] = 1e9;
  EXPECT_TRUE(contains(bad(r), "primitive.dimensions[1] (y) is 1e+09")) << bad(r);
  r.dimensions[1] = -0.1;
  EXPECT_TRUE(contains(bad(r), "must be > 0")) << bad(r);
  r = box_request("b");
  r.dimensions.pop_back();
  EXPECT_TRUE(contains(bad(r), "BOX needs 3 dimensions, got 2")) << bad(r);
  r = box_request("b");
  r.primitive_type = kCone;
  EXPECT_TRUE(contains(bad(r), "CONE")) << bad(r);
  r.primitive_type = 9;
  EXPECT_TRUE(contains(bad(r), "type 9 is unknown")) << bad(r);
  r = box_request("b");
  r.primitive_type = kNoPrimitive;
  EXPECT_TRUE(contains(bad(r), "no shape")) << bad(r);
  r = box_request("b");
  r.plane = {0, 0, 1, 0};
  EXPECT_TRUE(contains(bad(r), "more than one shape")) << bad(r);
  r = box_request("");
  EXPECT_TRUE(contains(bad(r), "name is empty")) << bad(r);
  r = box_request("b");
  r.friction = -1.0;
  EXPECT_TRUE(contains(bad(r), "friction is -1")) << bad(r);
  r = box_request("m");
  r.primitive_type = kNoPrimitive;
  r.vertices = {{0, 0, 0}, {1, 0, 0}, {0, nan, 0}};
  r.triangles = {{0, 1, 2}};
  EXPECT_TRUE(contains(bad(r), "mesh.vertices[2] is not finite")) << bad(r);
  r.vertices[2].y() = 1.0;
  r.triangles = {{0, 1, 3}};
  EXPECT_TRUE(contains(bad(r), "mesh.triangles[0] has vertex index 3")) << bad(r);
}

TEST(RuntimeObstacles, AddReplaceRemoveKeepOtherIndices) {
  corde::ObstacleSet set;
  corde::Obstacle scene_box = obstacle_from_request(box_request("table"));
  set.add(scene_box);
  RuntimeObstacles rt;
  const Eigen::Isometry3d id = Eigen::Isometry3d::Identity();
  EXPECT_FALSE(rt.add(&set, obstacle_from_request(box_request("a")), "", id, 0.0, false));
  EXPECT_FALSE(rt.add(&set, obstacle_from_request(box_request("b")), "", id, 0.0, false));
  ASSERT_EQ(set.size(), 3);
  EXPECT_EQ(set.obstacle(2).name, "b");

  // A duplicate without replace, or a scene obstacle's name: refused, the set unchanged.
  EXPECT_TRUE(contains(
      error_of([&] { rt.add(&set, obstacle_from_request(box_request("a")), "", id, 0.0, false); }),
      "was added already"));
  EXPECT_TRUE(contains(error_of([&] {
                         rt.add(&set, obstacle_from_request(box_request("table")), "", id, 0.0,
                                false);
                       }),
                       "names an obstacle of the scene"));
  EXPECT_EQ(set.size(), 3);

  // Replace moves it in its slot.
  ObstacleRequest moved = box_request("a");
  moved.position = {1.0, 2.0, 3.0};
  EXPECT_TRUE(rt.add(&set, obstacle_from_request(moved), "", id, 0.0, true));
  EXPECT_EQ(set.obstacle(1).pose.translation(), corde::Vec3(1.0, 2.0, 3.0));

  // Removed: disabled in its slot, found by no query; the next add takes the slot.
  rt.remove(&set, "a");
  EXPECT_FALSE(set.obstacle(1).enabled);
  std::vector<corde::SegmentContact> found;
  std::vector<int> which;
  set.query(corde::Vec3(0.9, 2.0, 3.0), corde::Vec3(1.1, 2.0, 3.0), 1.0, &found, &which);
  EXPECT_TRUE(found.empty());
  EXPECT_TRUE(contains(error_of([&] { rt.remove(&set, "a"); }), "no run-time obstacle"));
  EXPECT_TRUE(contains(error_of([&] { rt.remove(&set, "table"); }), "no run-time obstacle"));
  EXPECT_FALSE(rt.add(&set, obstacle_from_request(box_request("c")), "", id, 0.0, false));
  EXPECT_EQ(set.size(), 3);
  EXPECT_EQ(set.obstacle(1).name, "c");
  EXPECT_TRUE(set.obstacle(1).enabled);
  EXPECT_EQ(set.obstacle(0).name, "table");
}

TEST(RuntimeObstacles, FarPlacementRefusedInWorldFrame) {
  corde::ObstacleSet set;
  RuntimeObstacles rt;
  Eigen::Isometry3d far = Eigen::Isometry3d::Identity();
  far.translation().x() = 1e6;
  const std::string e = error_of(
      [&] { rt.add(&set, obstacle_from_request(box_request("a")), "f", far, 0.0, false); });
  EXPECT_TRUE(contains(e, "has a position or size of 1e+06 m")) << e;
  EXPECT_EQ(set.size(), 0);
  EXPECT_TRUE(rt.entries().empty());
}

TEST(RuntimeObstacles, FollowsItsFrame) {
  corde::ObstacleSet set;
  RuntimeObstacles rt;
  Eigen::Isometry3d f = Eigen::Isometry3d::Identity();
  rt.add(&set, obstacle_from_request(box_request("a")), "fixture", f, 0.0, false);
  EXPECT_TRUE(set.obstacle(0).moving);
  f.translation().z() = 0.1;
  rt.set_frame_pose(0, f, 0.01, 5.0, 30.0, 0.05);
  for (int i = 0; i < 40; ++i) rt.before_step(&set, 1e-3);  // 0.1 m at the 5 m/s cap: 20 steps
  EXPECT_NEAR(set.obstacle(0).pose.translation().z(), 0.3 + 0.1, 1e-12);
  EXPECT_NEAR(rt.world_pose(0).translation().z(), 0.4, 1e-12);
}

}  // namespace
}  // namespace corde_sim
#endif
