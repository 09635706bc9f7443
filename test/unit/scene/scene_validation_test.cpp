// Invalid scenes are rejected before anything runs, with the offending key's path first.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "corde_sim/scene/scene.h"

namespace corde {
namespace {

// A valid scene; each test breaks one thing in it.
const char* kBase = R"(
name: base
time_step: 1.0e-5
duration: 0.1
rods:
  - name: cable
    elements: 10
    radius: 0.003
    material: {E: 3.0e7, G: 1.0e7, E_s: 5.0e9, rho: 2000}
    shape: {type: straight, start: [0, 0, 1], direction: [1, 0, 0], length: 1.0}
    boundary:
      - {clamp: start, kind: natural}
grasps:
  - {name: gripper, rod: cable, place: end}
)";

std::string replace(std::string text, const std::string& from, const std::string& to) {
  const size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << "test bug: '" << from << "' not in the base scene";
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

// Parses and expects a SceneError whose message starts with `path` and contains `fragment`.
void expect_error(const std::string& yaml, const std::string& path, const std::string& fragment,
                  const std::vector<std::string>& overrides = {}) {
  try {
    parse_scene(yaml, overrides);
    ADD_FAILURE() << "no error; expected '" << path << ": ..." << fragment << "'";
  } catch (const SceneError& e) {
    const std::string msg = e.what();
    EXPECT_EQ(msg.rfind(path + ":", 0), 0u) << "message: " << msg;
    EXPECT_NE(msg.find(fragment), std::string::npos) << "message: " << msg;
  }
}

TEST(SceneValidation, BaseSceneIsValid) { EXPECT_NO_THROW(parse_scene(kBase)); }

TEST(SceneValidation, YamlSyntaxErrorNamesTheLine) {
  expect_error("rods: [\n  {name: a,\n", "<string>", "YAML syntax error");
}

TEST(SceneValidation, UnknownKeys) {
  expect_error(replace(kBase, "duration: 0.1", "duration: 0.1\ncolour: red"), "colour",
               "unknown key");
  expect_error(replace(kBase, "elements: 10", "elements: 10\n    segmnets: 4"), "rods[0].segmnets",
               "unknown key");
  expect_error(replace(kBase, "rho: 2000", "rho: 2000, Young: 1"), "rods[0].material.Young",
               "unknown key");
  expect_error(replace(kBase, "length: 1.0", "length: 1.0, turns: 3"), "rods[0].shape.turns",
               "unknown key");
}

TEST(SceneValidation, WrongTypes) {
  expect_error(replace(kBase, "elements: 10", "elements: many"), "rods[0].elements",
               "expected a number");
  expect_error(replace(kBase, "elements: 10", "elements: 2.5"), "rods[0].elements",
               "expected an integer");
  expect_error(replace(kBase, "duration: 0.1", "duration: 0.1\ngravity: [0, -9.81]"), "gravity",
               "expected [x, y, z]");
  expect_error(replace(kBase, "place: end}", "place: end, hold_orientation: maybe}"),
               "grasps[0].hold_orientation", "expected true or false");
  expect_error(replace(kBase, "rods:", "rods: {}\nx:"), "rods", "expected a list");
  expect_error(replace(kBase, "shape: {", "shape: [1, 2]\n    s: {"), "rods[0].shape",
               "expected a map");
}

TEST(SceneValidation, NonPositiveSizes) {
  expect_error(replace(kBase, "elements: 10", "elements: 0"), "rods[0].elements", "must be >= 1");
  expect_error(replace(kBase, "radius: 0.003", "radius: -0.003"), "rods[0].radius",
               "must be > 0, got -0.003");
  expect_error(replace(kBase, "time_step: 1.0e-5", "time_step: 0"), "time_step", "must be > 0");
  expect_error(replace(kBase, "duration: 0.1", "duration: -1"), "duration", "must be > 0");
  expect_error(replace(kBase, "length: 1.0", "length: 0"), "rods[0].shape.length", "must be > 0");
}

TEST(SceneValidation, NegativeOrMissingMaterialValues) {
  expect_error(replace(kBase, "E: 3.0e7", "E: -5"), "rods[0].material.E", "must be > 0, got -5");
  expect_error(replace(kBase, "G: 1.0e7", "G: 0"), "rods[0].material.G", "must be > 0");
  expect_error(replace(kBase, "rho: 2000", "rho: 2000, gamma_t: -1"), "rods[0].material.gamma_t",
               "must be >= 0");
  expect_error(replace(kBase, ", rho: 2000", ""), "rods[0].material", "needs rho");
  expect_error(replace(kBase, "G: 1.0e7, ", ""), "rods[0].material", "needs G, nu or C");
  expect_error(replace(kBase, "E: 3.0e7", "E: 3.0e7, B: 1"), "rods[0].material", "either E or B");
  expect_error(replace(kBase, "G: 1.0e7", "nu: 0.7"), "rods[0].material.nu", "(-1, 0.5]");
  expect_error(replace(kBase, "    radius: 0.003\n", ""), "rods[0].radius", "missing");
}

TEST(SceneValidation, NotANumber) {
  expect_error(replace(kBase, "time_step: 1.0e-5", "time_step: .nan"), "time_step",
               "finite number");
  expect_error(replace(kBase, "start: [0, 0, 1]", "start: [0, .inf, 1]"), "rods[0].shape.start[1]",
               "finite number");
}

TEST(SceneValidation, IndicesOutOfRange) {
  expect_error(replace(kBase, "{clamp: start, kind: natural}", "{node: 11, fix: true}"),
               "rods[0].boundary[0].node", "out of range (0..10");
  expect_error(replace(kBase, "{clamp: start, kind: natural}", "{segment: 10, fix: true}"),
               "rods[0].boundary[0].segment", "out of range (0..9");
  expect_error(replace(kBase, "    boundary:",
                       "    loads:\n      - {node: -1, force: [0, 0, 1]}\n"
                       "    boundary:"),
               "rods[0].loads[0].node", "out of range");
  expect_error(replace(kBase, "place: end}", "place: node, value: 12}"), "grasps[0].value",
               "out of range");
  expect_error(replace(kBase, "place: end}", "place: arc_length, value: 1.5}"), "grasps[0].value",
               "beyond the rod's length");
}

// A load's node or segment is read with the rod's description and resolved against the built
// rod: the messages name the key and the value given, with the range of the rod as built.
TEST(SceneValidation, LoadIndicesResolvedAgainstTheRod) {
  const auto with_load = [](const std::string& load) {
    return replace(kBase, "    boundary:", "    loads:\n      - " + load + "\n    boundary:");
  };
  expect_error(with_load("{node: 2.5, force: [0, 0, 1]}"), "rods[0].loads[0].node",
               "node index '2.5' out of range (0..10, start or end)");
  expect_error(with_load("{segment: 10, torque: [0, 0, 1]}"), "rods[0].loads[0].segment",
               "segment index '10' out of range (0..9, start or end)");
  expect_error(with_load("{node: [1], force: [0, 0, 1]}"), "rods[0].loads[0].node",
               "expected a node index, start or end");
  expect_error(with_load("{node: middle, force: [0, 0, 1]}"), "rods[0].loads[0].node",
               "expected a node index, start or end, got");
  const Scene scene = parse_scene(
      with_load("{node: end, force: [0, 0, 1]}\n      - {segment: end, torque: [1, 0, 0]}"));
  const Rod& rod = scene.world.rods()[0];
  ASSERT_EQ(rod.loads().size(), 2u);
  EXPECT_EQ(rod.loads()[0].index, 10);
  EXPECT_EQ(rod.loads()[1].index, 9);
}

TEST(SceneValidation, UnknownNames) {
  expect_error(
      replace(kBase, "material: {E: 3.0e7, G: 1.0e7, E_s: 5.0e9, rho: 2000}", "material: rubber"),
      "rods[0].material", "unknown material preset 'rubber'");
  expect_error(replace(kBase, "material: {E: 3.0e7,", "material: {preset: steel, E: 3.0e7,"),
               "rods[0].material.preset", "unknown material preset 'steel'");
  expect_error(replace(kBase, "rod: cable", "rod: rope"), "grasps[0].rod", "no rod named 'rope'");
  expect_error(replace(kBase, "type: straight", "type: spiral"), "rods[0].shape.type",
               "expected one of straight, helix, polyline");
  expect_error(replace(kBase, "duration: 0.1", "duration: 0.1\nintegrator: rk4"), "integrator",
               "semi_implicit_euler");
  expect_error(replace(kBase, "kind: natural", "kind: welded"), "rods[0].boundary[0].kind",
               "natural, ghost");
}

TEST(SceneValidation, Duplicates) {
  const std::string two_rods = replace(
      kBase, "grasps:",
      "  - {name: cable, radius: 0.003, material: soft_cable, shape: {type: straight}}\ngrasps:");
  expect_error(two_rods, "rods[1].name", "duplicate rod name 'cable' (also rods[0])");
  expect_error(replace(kBase, "place: end}", "place: end}\n  - {name: gripper, place: start}"),
               "grasps[1].name", "duplicate grasp name");
}

TEST(SceneValidation, ZeroVectors) {
  expect_error(replace(kBase, "direction: [1, 0, 0]", "direction: [0, 0, 0]"),
               "rods[0].shape.direction", "zero vector");
  expect_error(replace(kBase, "elements: 10", "elements: 10\n    reference_d1: [0, 0, 0]"),
               "rods[0].reference_d1", "zero vector");
  expect_error(replace(kBase, "type: straight, start: [0, 0, 1], direction: [1, 0, 0], length: 1.0",
                       "type: polyline, points: [[0, 0, 0], [0, 0, 0], [1, 0, 0]]"),
               "rods[0].shape.points[1]", "repeats the previous point");
}

TEST(SceneValidation, MissingRequiredKeys) {
  expect_error(replace(kBase,
                       "    shape: {type: straight, start: [0, 0, 1], direction: [1, 0, 0], "
                       "length: 1.0}\n",
                       ""),
               "rods[0].shape", "missing (required)");
  expect_error("name: empty\n", "rods", "missing (required)");
  expect_error(replace(kBase, "{name: gripper, rod: cable, place: end}", "{rod: cable}"),
               "grasps[0].name", "missing");
  expect_error(replace(kBase, "place: end}", "place: node}"), "grasps[0].value", "missing");
  expect_error(replace(kBase, "type: straight, start: [0, 0, 1], direction: [1, 0, 0], length: 1.0",
                       "type: helix, radius: 0.1, pitch: 0.02"),
               "rods[0].shape", "needs one of turns, length");
}

TEST(SceneValidation, ConflictingConstraints) {
  expect_error(replace(kBase, "{clamp: start, kind: natural}",
                       "{clamp: start, kind: natural}\n      - {node: 0, velocity: [0, 0, 1]}"),
               "rods[0].boundary[1].node", "node 0 is already constrained by rods[0].boundary[0]");
  expect_error(replace(kBase, "{clamp: start, kind: natural}",
                       "{clamp: end}\n      - {segment: 0, fix: true}"),
               "grasps[0]", "already constrained by rods[0].boundary[0]");
  expect_error(replace(kBase, "{clamp: start, kind: natural}", "{node: 0, segment: 0, fix: true}"),
               "rods[0].boundary[0]", "give only one of node, segment, clamp");
  expect_error(replace(kBase, "{clamp: start, kind: natural}", "{node: 0, fix: false}"),
               "rods[0].boundary[0].fix", "must be true");
  expect_error(replace(kBase, "place: end}", "place: end, value: 3}"), "grasps[0].value",
               "only used with place");
}

TEST(SceneValidation, BadOverrides) {
  expect_error(kBase, "rods[0].elemnts", "unknown key", {"rods.0.elemnts=5"});
  expect_error(kBase, "rods", "no item '3'", {"rods.3.elements=5"});
  expect_error(kBase, "rods", "no item 'rope'", {"rods.rope.elements=5"});
  expect_error(kBase, "elements", "must look like key.path=value", {"elements"});
  expect_error(kBase, "rods[0].elements", "must be >= 1", {"rods[0].elements=0"});
  expect_error(kBase, "rods[0].radius", "is not a map", {"rods.0.radius.x=1"});
}

TEST(SceneValidation, MissingFile) {
  try {
    load_scene("/nonexistent/scene.yaml");
    ADD_FAILURE() << "no error";
  } catch (const SceneError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/scene.yaml: cannot open"),
              std::string::npos);
  }
}

}  // namespace
}  // namespace corde
