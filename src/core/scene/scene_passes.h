// Internal to the scene loader: the three passes of parse_scene() (docs/architecture.md, "Scene
// loading").
//   (a) describe_scene: the YAML tree (overrides applied) into a SceneDescription: the top-level
//       settings, each rod's own keys (name, elements, material, shape, drag, contact, initial
//       state, loads with their node or segment unresolved) and what the scene asks of the
//       automatic pass, read and validated; nothing built.
//   (b) build_scene: the rods built from their descriptions, then the entries that need a built
//       rod, read in file order against the rods built before them (node and segment indices,
//       `end`, keyframes given as absolute poses and arc lengths): each rod's initial velocities,
//       boundary, loads (indices resolved) and rotational_inertia_scale, then contact settings,
//       obstacles, grasps.
//   (c) make_automatic_choices: on the built scene, initial_state: equilibrium, then time_step:
//       auto and integrator: auto, each logged with its reason in Scene::notes or settled. It
//       counts work, never time, so the result depends on the scene only. (elements: auto runs
//       before (b): it rewrites the tree after probe runs of (b) and (c) at two resolutions,
//       scene_elements.h.)
// A file with one error gives the same error as when the loader read and built in one go; of
// several errors in different rods, the first in pass (a) is reported.
#pragma once

#include <yaml-cpp/yaml.h>

#include <optional>
#include <string>
#include <vector>

#include "corde_sim/model/loads.h"
#include "corde_sim/scene/scene.h"
#include "scene_reader.h"

namespace corde {
namespace scene_detail {

// What pass (c) is asked to do, with the keys that asked (for messages).
struct AutomaticRequests {
  struct Equilibrium {
    int rod = 0;
    std::string rod_path;  // "rods[1]"
    Value key;             // the initial_state key (the rod's own or the scene's)
  };
  std::vector<Equilibrium> equilibrium;
  std::optional<Value> time_step;  // the given time_step key; none: time_step: auto
  bool integrator_auto = false;
};

// A node or segment as the file gives it: `start`, `end` or an index, resolved against the built
// rod in pass (b) (which checks the range and names `key` when it is out of it).
struct IndexRef {
  enum class Kind { kStart, kEnd, kIndex };
  Kind kind = Kind::kStart;
  double index = 0.0;  // kIndex: the number given (any value; the range is checked on resolving)
  Value key{YAML::Node(), ""};
};

// A `loads` entry: the load with its index unresolved.
struct LoadDescription {
  std::string path;  // "rods[0].loads[1]"
  Load load;         // all but index
  IndexRef at;       // the node (force) or segment (torque)
};

// A rod's own keys, read in pass (a).
struct RodDescription {
  std::string path;  // "rods[0]"
  RodSpec spec;      // name, elements, section (material, radius), shape, reference_d1, rest_shape
  std::optional<Drag> drag;
  std::optional<ContactOptions> contact;
  std::optional<Value> equilibrium;  // the initial_state key that asks for it (the rod's or the
                                     // scene's)
  std::vector<LoadDescription> loads;
  // Its map: pass (b) reads initial, boundary and rotational_inertia_scale from it, then refuses
  // unknown keys.
  std::optional<Map> map;
};

// Pass (a)'s result.
struct SceneDescription {
  std::string source;  // names the text in messages
  std::string base;    // folder of relative paths (keyframe files, URDFs): the scene file's
  std::string name, description;
  std::optional<Vec3> gravity;  // m/s^2; none: the world's default
  Integrator integrator = kDefaultIntegrator;
  bool integrator_auto = false;
  double duration = 1.0;  // s
  Scene::Mode mode = Scene::Mode::kDynamics;
  double statics_time = 0.0;        // s
  std::optional<double> time_step;  // s; none: time_step: auto
  std::optional<Value> time_step_key;
  std::vector<std::string> warnings;
  std::vector<RodDescription> rods;  // at least one, at most SceneLimits::max_rods
  // The entries pass (b) reads: contact settings, obstacles, grasps.
  std::optional<Value> contact, obstacles, grasps;
  // The top-level map, whose unknown keys pass (b) refuses once every entry is read.
  std::optional<Map> top;
};

SceneDescription describe_scene(const YAML::Node& root, const std::string& source);
Scene build_scene(SceneDescription* description, AutomaticRequests* requests);
void make_automatic_choices(Scene* scene, const AutomaticRequests& requests);

// The items of a list, failing when there are more than `limit` of them.
std::vector<Value> limited_items(const Value& list, int limit, const char* what);
// `initial_state`: given (the shape and velocities as described) or equilibrium.
bool wants_equilibrium(const Value& v);
// "start", "end" or a number, unresolved (pass a); fails on anything else, naming `what`.
IndexRef describe_index(const Value& v, const char* what);
// The index in [0, count) that `ref` names (pass b); fails naming the key when out of range.
int resolve_index(const IndexRef& ref, int count, const char* what);

}  // namespace scene_detail
}  // namespace corde
