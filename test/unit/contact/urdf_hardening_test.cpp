// Hostile and careless URDFs and meshes (issue 22): deep link chains, files of the wrong type or
// size, collision elements urdfdom drops without a word, absurd sizes, and clear messages.
#include <gtest/gtest.h>
#include <pthread.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "corde_sim/contact/urdf_obstacles.h"
#include "corde_sim/scene/scene.h"

namespace corde {
namespace {

namespace fs = std::filesystem;

// The message of the runtime_error `f` throws ("" if none).
template <typename F>
std::string error_of(const F& f) {
  try {
    f();
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

#define EXPECT_HAS(text, part) \
  EXPECT_TRUE(contains(text, part)) << "'" << (part) << "' not in: " << (text)

class UrdfHardening : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("corde_urdf_hard_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string write(const std::string& name, const std::string& text) {
    const fs::path file = dir_ / name;
    std::ofstream(file, std::ios::binary) << text;
    return file.string();
  }

  // A file of `bytes` bytes without writing them (sparse).
  std::string sparse(const std::string& name, std::uintmax_t bytes) {
    const std::string path = write(name, "");
    fs::resize_file(path, bytes);
    return path;
  }

  fs::path dir_;
};

// `n` links l0 ... l<n-1> joined by fixed joints, a box on the root link.
std::string chain(int n) {
  std::string s =
      "<robot name='chain'>\n<link name='l0'><collision><geometry><box size='1 1 1'/>"
      "</geometry></collision></link>\n";
  s.reserve(static_cast<size_t>(n) * 100);
  for (int i = 1; i < n; ++i) {
    const std::string a = std::to_string(i - 1), b = std::to_string(i);
    s += "<link name='l" + b + "'/><joint name='j" + b + "' type='fixed'><parent link='l" + a +
         "'/><child link='l" + b + "'/></joint>\n";
  }
  return s + "</robot>\n";
}

// One link 'table' with the given collision element.
std::string table(const std::string& collision) {
  return "<robot name='t'><link name='table'>" + collision + "</link></robot>";
}

std::string box_collision(const std::string& size, const std::string& origin = "") {
  return "<collision>" + origin + "<geometry><box size='" + size + "'/></geometry></collision>";
}

// A deep chain used to overflow the stack in the recursive link walk (SIGSEGV at 10000 links).
TEST_F(UrdfHardening, DeepChainLoads) {
  const std::string path = write("chain.urdf", chain(10000));
  const std::vector<Obstacle> obs = load_urdf_obstacles(path);
  ASSERT_EQ(obs.size(), 1u);
  EXPECT_EQ(obs[0].name, "l0");
}

// Runs `f` in a thread with a stack of `bytes` (the node loads in its service threads).
template <typename F>
void on_stack(size_t bytes, F f) {
  pthread_attr_t attr;
  pthread_attr_init(&attr);
  pthread_attr_setstacksize(&attr, bytes);
  pthread_t thread;
  auto run = [](void* arg) -> void* {
    (*static_cast<F*>(arg))();
    return nullptr;
  };
  ASSERT_EQ(pthread_create(&thread, &attr, run, &f), 0);
  pthread_join(thread, nullptr);
  pthread_attr_destroy(&attr);
}

TEST_F(UrdfHardening, LinkLimit) {
  const std::string at = write("at.urdf", chain(SceneLimits::max_urdf_links));
  // urdfdom's model destroyed a chain by recursion: more than 1 MB of stack for 100000 links.
  size_t loaded = 0;
  on_stack(1 << 20, [&] { loaded = load_urdf_obstacles(at).size(); });
  EXPECT_EQ(loaded, 1u);
  const std::string over = write("over.urdf", chain(SceneLimits::max_urdf_links + 1));
  const std::string msg = error_of([&] { load_urdf_obstacles(over); });
  EXPECT_HAS(msg, over);
  EXPECT_HAS(msg, "100001 links, more than the limit of 100000");
}

// XML nested deeper than any URDF needs is refused before the XML parser (which recurses).
TEST_F(UrdfHardening, DeepNesting) {
  std::string xml = "<robot name='x'><link name='a'/>";
  const int depth = 1000000;
  for (int i = 0; i < depth; ++i) xml += "<a>";
  for (int i = 0; i < depth; ++i) xml += "</a>";
  xml += "</robot>";
  const std::string msg = error_of([&] { parse_urdf_obstacles(xml, ""); });
  EXPECT_HAS(msg, "<urdf string>");
  EXPECT_HAS(msg, "nested deeper than");
}

// A link reached through two joints was walked twice (a lattice of such links exponentially
// often); a cycle of joints beside the root was skipped without a word.
TEST_F(UrdfHardening, NotATree) {
  const std::string two_parents =
      "<robot name='x'><link name='a'/><link name='b'/><link name='c'>" + box_collision("1 1 1") +
      "</link><joint name='j1' type='fixed'><parent link='a'/><child link='c'/></joint>"
      "<joint name='j2' type='fixed'><parent link='b'/><child link='c'/></joint>"
      "<joint name='j3' type='fixed'><parent link='a'/><child link='b'/></joint></robot>";
  std::string msg = error_of([&] { parse_urdf_obstacles(two_parents, ""); });
  EXPECT_HAS(msg, "link 'c' is the child of two joints, 'j1' and 'j2'");
  const std::string cycle =
      "<robot name='x'><link name='r'/><link name='a'/><link name='b'>" + box_collision("1 1 1") +
      "</link><joint name='ab' type='fixed'><parent link='a'/><child link='b'/></joint>"
      "<joint name='ba' type='fixed'><parent link='b'/><child link='a'/></joint></robot>";
  msg = error_of([&] { parse_urdf_obstacles(cycle, ""); });
  EXPECT_HAS(msg, "lies on a cycle of joints");
  // urdfdom would fail only after linking the chain, then destroy it by recursion.
  std::string long_chain = chain(SceneLimits::max_urdf_links - 1);
  long_chain.resize(long_chain.size() - std::string("</robot>\n").size());
  const std::string two_roots = long_chain + "<link name='other'/></robot>";
  const std::string missing =
      long_chain + "<joint name='x' type='fixed'><parent link='l0'/><child link='nope'/></joint>" +
      "</robot>";
  on_stack(1 << 20, [&] {
    msg = error_of([&] { parse_urdf_obstacles(two_roots, ""); });
    EXPECT_HAS(msg, "two root links");
    msg = error_of([&] { parse_urdf_obstacles(missing, ""); });
    EXPECT_HAS(msg, "joint 'x': link 'nope' is not a link of the robot");
  });
}

TEST_F(UrdfHardening, FileTypeAndSize) {
  // /dev/zero used to grow memory without end; a FIFO blocked forever.
  std::string msg = error_of([&] { load_urdf_obstacles("/dev/zero"); });
  EXPECT_HAS(msg, "/dev/zero: is not a regular file");
  const std::string fifo = (dir_ / "fifo.urdf").string();
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  msg = error_of([&] { load_urdf_obstacles(fifo); });
  EXPECT_HAS(msg, fifo + ": is not a regular file");
  const std::string big = sparse("big.urdf", SceneLimits::max_urdf_bytes + 1);
  msg = error_of([&] { load_urdf_obstacles(big); });
  EXPECT_HAS(msg, big + ": larger than the limit of 16777216 bytes");
  // The same limit for URDF text given as a string (the node's robot_description).
  msg = error_of([&] {
    parse_urdf_collisions(std::string(SceneLimits::max_urdf_bytes + 1, ' '), "", "parameter /rd");
  });
  EXPECT_HAS(msg, "parameter /rd: larger than the limit of 16777216 bytes");
}

TEST_F(UrdfHardening, MeshFileTypeAndSize) {
  const std::string fifo = (dir_ / "fifo.stl").string();
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  std::string msg = error_of([&] { load_mesh_file(fifo); });
  EXPECT_HAS(msg, fifo + ": is not a regular file");
  const std::string big = sparse("big.stl", SceneLimits::max_mesh_bytes + 1);
  msg = error_of([&] { load_mesh_file(big); });
  EXPECT_HAS(msg, big + ": larger than the limit of 67108864 bytes");
  // Through a URDF: the link and element named.
  const std::string urdf = write(
      "m.urdf", table("<collision><geometry><mesh filename='fifo.stl'/></geometry></collision>"));
  msg = error_of([&] { load_urdf_obstacles(urdf); });
  EXPECT_HAS(msg, "link 'table' collision 0");
  EXPECT_HAS(msg, "is not a regular file");
}

// A binary STL of `n` triangles (all the same small one).
std::string binary_stl(std::uint32_t n) {
  std::string s(80, ' ');
  s.append(reinterpret_cast<const char*>(&n), 4);
  std::string facet(50, '\0');
  const float v[12] = {0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0};
  std::memcpy(&facet[0], v, sizeof v);
  s.reserve(s.size() + 50ull * n);
  for (std::uint32_t i = 0; i < n; ++i) s += facet;
  return s;
}

TEST_F(UrdfHardening, MeshTriangleLimit) {
  const std::string path = write(
      "many.stl", binary_stl(static_cast<std::uint32_t>(SceneLimits::max_mesh_triangles + 1)));
  const std::string msg = error_of([&] { load_mesh_file(path); });
  EXPECT_HAS(msg, path);
  EXPECT_HAS(msg, "more than the limit of 1000000");
}

// Collision elements urdfdom skips (their geometry or origin does not parse) used to vanish: a
// rope fell through such a table.
TEST_F(UrdfHardening, DroppedCollisionsRefused) {
  const std::vector<std::string> bad = {
      box_collision("1,1,0.1"),
      box_collision("nan 1 1"),
      box_collision("1 1 1", "<origin xyz='nan 0 0'/>"),
      box_collision("1 1 1", "<origin rpy='0 x 0'/>"),
      "<collision><geometry><mesh filename='a.stl' scale='a b c'/></geometry></collision>",
      "<collision><geometry></geometry></collision>",
      "<collision><geometry><cone radius='1'/></geometry></collision>",
      "<collision><geometry><cylinder radius='1'/></geometry></collision>",
  };
  for (const std::string& c : bad) {
    const std::string path = write("bad.urdf", table(box_collision("1 1 1") + c));
    const std::string msg = error_of([&] { load_urdf_obstacles(path); });
    EXPECT_HAS(msg, path);
    EXPECT_HAS(msg, "link 'table' collision 1");
    // The same through the node's entry point.
    const std::string m2 =
        error_of([&] { parse_urdf_collisions(table(c), "", "parameter /robot_description"); });
    EXPECT_HAS(m2, "parameter /robot_description: link 'table' collision 0");
  }
}

// Sizes and positions far beyond any robot used to load, then stop the run at t = 0 (FCL's
// Jacobi transform on 1e308).
TEST_F(UrdfHardening, AbsurdSizesRefused) {
  write("cube.stl", binary_stl(1));
  const std::vector<std::pair<std::string, std::string>> bad = {
      {box_collision("1e308 1 1"), "box size"},
      {box_collision("1 1 1", "<origin xyz='0 1e308 0'/>"), "origin"},
      {box_collision("1 1 1", "<origin xyz='0 2e4 0'/>"), "origin"},
      {"<collision><geometry><sphere radius='1e308'/></geometry></collision>", "sphere radius"},
      {"<collision><geometry><cylinder radius='1' length='1e308'/></geometry></collision>",
       "cylinder length"},
      {"<collision><geometry><mesh filename='cube.stl' scale='1e308 1 1'/></geometry></collision>",
       "mesh scale"},
      {"<collision><geometry><mesh filename='cube.stl' scale='0 1 1'/></geometry></collision>",
       "mesh scale"},
      {box_collision("0 1 1"), "box size"},
  };
  for (const auto& [c, what] : bad) {
    const std::string path = write("big.urdf", table(c));
    const std::string msg = error_of([&] { load_urdf_obstacles(path); });
    EXPECT_HAS(msg, "link 'table' collision 0");
    EXPECT_HAS(msg, what);
  }
  // A joint's origin that far out, too.
  const std::string joint =
      "<robot name='r'><link name='a'/><link name='b'>" + box_collision("1 1 1") +
      "</link><joint name='j' type='fixed'><parent link='a'/><child link='b'/>"
      "<origin xyz='1e300 0 0'/></joint></robot>";
  const std::string msg = error_of([&] { parse_urdf_obstacles(joint, ""); });
  EXPECT_HAS(msg, "joint 'j'");
  // At the limit still loads.
  EXPECT_EQ(
      parse_urdf_obstacles(table(box_collision("1e4 1 1", "<origin xyz='1e4 0 0'/>")), "").size(),
      1u);
}

TEST_F(UrdfHardening, ClearMessages) {
  const std::string text = write("notes.urdf", "just some words\n");
  std::string msg = error_of([&] { load_urdf_obstacles(text); });
  EXPECT_HAS(msg, text + ": not a URDF (no <robot> element)");
  const std::string other = write("other.urdf", "<?xml version='1.0'?><scene/>");
  msg = error_of([&] { load_urdf_obstacles(other); });
  EXPECT_HAS(msg, other + ": not a URDF (no <robot> element)");
  msg = error_of([&] { load_urdf_obstacles(dir_.string()); });
  EXPECT_HAS(msg, dir_.string() + ": is a directory");
  msg = error_of([&] { parse_urdf_obstacles("", ""); });
  EXPECT_HAS(msg, "<urdf string>: not a URDF (no <robot> element)");
}

std::string scene_error(const std::string& urdf_value) {
  const std::string yaml = R"(time_step: 1.0e-5
duration: 0.001
rods:
  - {name: cable, elements: 4, material: {preset: soft_cable},
     shape: {type: straight, start: [0, 0, 1], direction: [1, 0, 0], length: 0.2}}
obstacles:
  - {urdf: )" + urdf_value +
                           "}\n";
  try {
    parse_scene(yaml);
  } catch (const SceneError& e) {
    return e.what();
  }
  return "";
}

TEST_F(UrdfHardening, SceneKeyMessages) {
  EXPECT_HAS(scene_error("\"\""), "obstacles[0].urdf: the path is empty");
  EXPECT_HAS(scene_error(dir_.string()), "is a directory");
  const std::string deep = write("chain.urdf", chain(10000));
  EXPECT_EQ(scene_error(deep), "");
  const std::string bad = write("bad.urdf", table(box_collision("1,1,0.1")));
  EXPECT_HAS(scene_error(bad), "link 'table' collision 0");
}

}  // namespace
}  // namespace corde
