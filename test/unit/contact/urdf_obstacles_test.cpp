// URDF collision elements as obstacles: shapes, poses by forward kinematics, meshes from files
// (an ASCII STL written here), package:// names, and errors naming the file and element.
#include "corde_sim/contact/urdf_obstacles.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

namespace corde {
namespace {

namespace fs = std::filesystem;

// A cube of side 1 centred at the origin as an ASCII STL (12 facets, outward).
void write_cube_stl(const fs::path& file) {
  fs::create_directories(file.parent_path());
  std::ofstream out(file);
  out << "solid cube\n";
  const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                           {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  auto corner = [](int i) {
    return Vec3(i & 1 ? 0.5 : -0.5, i & 2 ? 0.5 : -0.5, i & 4 ? 0.5 : -0.5);
  };
  for (const auto& q : quads) {
    for (const auto& tri : {std::array<int, 3>{q[0], q[1], q[2]}, {q[0], q[2], q[3]}}) {
      const Vec3 n = (corner(tri[1]) - corner(tri[0])).cross(corner(tri[2]) - corner(tri[0]));
      out << " facet normal " << n.x() << " " << n.y() << " " << n.z() << "\n  outer loop\n";
      for (int k : tri) {
        const Vec3 v = corner(k);
        out << "   vertex " << v.x() << " " << v.y() << " " << v.z() << "\n";
      }
      out << "  endloop\n endfacet\n";
    }
  }
  out << "endsolid cube\n";
}

std::string robot(const std::string& mesh_name, const std::string& box_size = "1 2 3") {
  return R"(<?xml version="1.0"?>
<robot name="arm_robot">
  <link name="base_link">
    <collision><origin xyz="0 0 -1.5"/><geometry><box size=")" +
         box_size + R"("/></geometry></collision>
  </link>
  <joint name="shoulder" type="revolute">
    <parent link="base_link"/><child link="arm"/>
    <origin xyz="0 0 1"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="1" velocity="1"/>
  </joint>
  <link name="arm">
    <collision><origin xyz="0.25 0 0" rpy="0 1.5707963267948966 0"/>
      <geometry><cylinder radius="0.1" length="0.5"/></geometry></collision>
    <collision><origin xyz="0.5 0 0"/><geometry><sphere radius="0.05"/></geometry></collision>
  </link>
  <joint name="tool_mount" type="fixed">
    <parent link="arm"/><child link="tool"/><origin xyz="0.5 0 0"/>
  </joint>
  <link name="tool">
    <collision><geometry><mesh filename=")" +
         mesh_name + R"(" scale="0.1 0.2 0.3"/></geometry></collision>
  </link>
  <link name="visual_only"><visual><geometry><box size="1 1 1"/></geometry></visual></link>
  <joint name="slide" type="prismatic">
    <parent link="base_link"/><child link="visual_only"/><axis xyz="1 0 0"/>
    <limit lower="0" upper="1" effort="1" velocity="1"/>
  </joint>
</robot>
)";
}

class UrdfObstacles : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("corde_urdf_test_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    write_cube_stl(dir_ / "my_pkg" / "meshes" / "cube.stl");
    std::ofstream(dir_ / "my_pkg" / "package.xml")
        << "<package format=\"3\"><name>my_pkg</name></package>\n";
    fs::create_directories(dir_ / "my_pkg" / "urdf");
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string write_urdf(const std::string& text) {
    const fs::path file = dir_ / "my_pkg" / "urdf" / "robot.urdf";
    std::ofstream(file) << text;
    return file.string();
  }

  fs::path dir_;
};

const Obstacle& by_name(const std::vector<Obstacle>& obs, const std::string& name) {
  for (const Obstacle& ob : obs) {
    if (ob.name == name) return ob;
  }
  throw std::runtime_error("no obstacle " + name);
}

TEST_F(UrdfObstacles, ShapesAndPoses) {
  const std::string path = write_urdf(robot("package://my_pkg/meshes/cube.stl"));
  const std::vector<Obstacle> obs = load_urdf_obstacles(path, {{"shoulder", M_PI / 2}});
  ASSERT_EQ(obs.size(), 4u);

  const Obstacle& base = by_name(obs, "base_link");
  EXPECT_EQ(base.shape.kind, ObstacleShape::Kind::kBox);
  EXPECT_LT((base.shape.size - Vec3(1.0, 2.0, 3.0)).norm(), 1e-12);
  EXPECT_LT((base.pose.translation() - Vec3(0.0, 0.0, -1.5)).norm(), 1e-12);
  EXPECT_FALSE(base.moving);

  // The arm turned a quarter about z: its x axis along the world's y.
  const Obstacle& cyl = by_name(obs, "arm/0");
  EXPECT_EQ(cyl.shape.kind, ObstacleShape::Kind::kCylinder);
  EXPECT_LT((cyl.shape.size.head<2>() - Eigen::Vector2d(0.1, 0.5)).norm(), 1e-12);
  EXPECT_LT((cyl.pose.translation() - Vec3(0.0, 0.25, 1.0)).norm(), 1e-12);
  EXPECT_LT((cyl.pose.linear().col(2) - Vec3::UnitY()).norm(), 1e-9);  // its axis along the arm
  EXPECT_TRUE(cyl.moving);
  const Obstacle& ball = by_name(obs, "arm/1");
  EXPECT_EQ(ball.shape.kind, ObstacleShape::Kind::kSphere);
  EXPECT_DOUBLE_EQ(ball.shape.size.x(), 0.05);
  EXPECT_LT((ball.pose.translation() - Vec3(0.0, 0.5, 1.0)).norm(), 1e-12);

  const Obstacle& tool = by_name(obs, "tool");
  ASSERT_EQ(tool.shape.kind, ObstacleShape::Kind::kMesh);
  ASSERT_TRUE(tool.shape.mesh);
  EXPECT_EQ(tool.shape.mesh->triangles.size(), 12u);
  Eigen::AlignedBox3d bounds;
  for (const Vec3& v : tool.shape.mesh->vertices) bounds.extend(v);
  EXPECT_LT((bounds.sizes() - Vec3(0.1, 0.2, 0.3)).norm(), 1e-6);  // scaled
  EXPECT_LT((tool.pose.translation() - Vec3(0.0, 0.5, 1.0)).norm(), 1e-12);
  EXPECT_LT((tool.pose.linear().col(0) - Vec3::UnitY()).norm(), 1e-9);
  EXPECT_TRUE(tool.moving);

  // Usable as obstacles: the tool's mesh, 0.3 high, reaches z = 1.15; a segment at z = 1.35 is
  // 0.2 above it (0.25 above the arm's cylinder, 0.3 above the ball).
  ObstacleSet set;
  for (const Obstacle& ob : obs) set.add(ob);
  std::vector<SegmentContact> out;
  std::vector<int> which;
  set.query(Vec3(-0.02, 0.5, 1.35), Vec3(0.02, 0.5, 1.35), 0.22, &out, &which);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(obs[which[0]].name, "tool");
  EXPECT_NEAR(out[0].distance, 0.2, 1e-9);
  EXPECT_LT((out[0].normal - Vec3::UnitZ()).norm(), 1e-9);

  // Zero joint values by default; relative mesh names; the same from a string.
  const std::vector<Obstacle> rest =
      parse_urdf_obstacles(robot("../meshes/cube.stl"), (dir_ / "my_pkg" / "urdf").string());
  EXPECT_LT((by_name(rest, "arm/1").pose.translation() - Vec3(0.5, 0.0, 1.0)).norm(), 1e-12);
}

// The message of the runtime_error `f` throws holds every fragment.
template <typename F>
void expect_error(const F& f, const std::vector<std::string>& fragments) {
  try {
    f();
    ADD_FAILURE() << "no error";
  } catch (const std::runtime_error& e) {
    const std::string msg = e.what();
    for (const std::string& frag : fragments) {
      EXPECT_NE(msg.find(frag), std::string::npos) << "'" << frag << "' not in: " << msg;
    }
  }
}

// Per element its link and the pose in the link (the collision origin): the node moves them
// with the link's tf frame. Every link's name is reported, also links without collisions.
TEST_F(UrdfObstacles, CollisionsWithTheirLinks) {
  const std::string xml = robot("package://my_pkg/meshes/cube.stl");
  std::vector<std::string> links;
  const std::vector<UrdfCollision> cols =
      parse_urdf_collisions(xml, (dir_ / "my_pkg" / "urdf").string(), "test robot", &links);
  ASSERT_EQ(cols.size(), 4u);
  std::sort(links.begin(), links.end());
  EXPECT_EQ(links, (std::vector<std::string>{"arm", "base_link", "tool", "visual_only"}));
  for (const UrdfCollision& c : cols) {
    if (c.obstacle.name == "arm/0") {
      EXPECT_EQ(c.link, "arm");
      EXPECT_LT((c.in_link.translation() - Vec3(0.25, 0.0, 0.0)).norm(), 1e-12);
      // The in-link pose times the link's pose at zero joints (z = 1) is the obstacle's pose.
      Eigen::Isometry3d link = Eigen::Isometry3d::Identity();
      link.translation() = Vec3(0.0, 0.0, 1.0);
      EXPECT_LT(((link * c.in_link).matrix() - c.obstacle.pose.matrix()).norm(), 1e-12);
    }
    if (c.obstacle.name == "tool") {
      EXPECT_EQ(c.link, "tool");
    }
  }
  try {
    parse_urdf_collisions("<robot name='x'><link name='a'/>", "", "parameter /robot_description");
    FAIL() << "a broken URDF parsed";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("parameter /robot_description"), std::string::npos)
        << e.what();
  }
}

TEST_F(UrdfObstacles, Errors) {
  const std::string good = robot("package://my_pkg/meshes/cube.stl");
  std::string path = write_urdf(good.substr(0, good.size() / 2));  // cut mid-element
  expect_error([&] { load_urdf_obstacles(path); }, {path, "not a valid URDF"});

  path = write_urdf(robot("package://my_pkg/meshes/missing.stl"));
  expect_error([&] { load_urdf_obstacles(path); },
               {path, "link 'tool'", "missing.stl", "does not exist"});

  path = write_urdf(robot("package://no_such_pkg/cube.stl"));
  expect_error([&] { load_urdf_obstacles(path); }, {path, "link 'tool'", "no_such_pkg"});

  std::ofstream(dir_ / "my_pkg" / "meshes" / "broken.stl") << "solid x\n facet normal 0 0 1\n";
  path = write_urdf(robot("package://my_pkg/meshes/broken.stl"));
  expect_error([&] { load_urdf_obstacles(path); }, {path, "link 'tool'", "broken.stl"});

  path = write_urdf(robot("package://my_pkg/meshes/cube.stl", "1 -2 3"));
  expect_error([&] { load_urdf_obstacles(path); }, {path, "base_link"});

  path = write_urdf(good);
  expect_error([&] { load_urdf_obstacles(path, {{"elbow", 1.0}}); }, {path, "joint 'elbow'"});

  expect_error([&] { load_urdf_obstacles((dir_ / "nothing.urdf").string()); },
               {"nothing.urdf", "cannot open the URDF"});
  expect_error([&] { parse_urdf_obstacles("<robot name='x'><link name=", ""); },
               {"<urdf string>", "not a valid URDF"});
}

TEST_F(UrdfObstacles, MeshFileScaleMirrors) {
  // A negative scale mirrors the mesh; its winding is reversed so that it stays outward.
  const TriangleMesh m =
      load_mesh_file((dir_ / "my_pkg" / "meshes" / "cube.stl").string(), Vec3(-1.0, 1.0, 1.0));
  Vec3 centroid = Vec3::Zero();
  for (const Vec3& v : m.vertices) centroid += v;
  centroid /= static_cast<double>(m.vertices.size());
  for (const Eigen::Vector3i& t : m.triangles) {
    const Vec3 n = (m.vertices[t[1]] - m.vertices[t[0]]).cross(m.vertices[t[2]] - m.vertices[t[0]]);
    EXPECT_GT(n.dot(m.vertices[t[0]] - centroid), 0.0);
  }
}

}  // namespace
}  // namespace corde

// File names as the scene key `urdf` takes them: package:// found from the scene's folder (the
// package's root holds package.xml naming corde_sim), file://, absolute and relative names.
TEST(ResolveResourcePath, PackageFileAbsoluteRelative) {
  namespace fs = std::filesystem;
  const std::string root = CORDE_SIM_SOURCE_DIR;
  const std::string scenes = root + "/config/scenes";
  const std::string got =
      corde::resolve_resource_path("package://corde_sim/urdf/table_with_bar.urdf", scenes);
  EXPECT_TRUE(fs::equivalent(got, root + "/urdf/table_with_bar.urdf")) << got;
  EXPECT_EQ(corde::resolve_resource_path("file:///a/b.urdf", scenes), "/a/b.urdf");
  EXPECT_EQ(corde::resolve_resource_path("/a/b.urdf", scenes), "/a/b.urdf");
  EXPECT_EQ(corde::resolve_resource_path("../../urdf/x.urdf", scenes),
            scenes + "/../../urdf/x.urdf");
  try {
    corde::resolve_resource_path("package://no_such_package_here/x.urdf", scenes);
    ADD_FAILURE() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("package 'no_such_package_here' not found"),
              std::string::npos)
        << e.what();
  }
}
