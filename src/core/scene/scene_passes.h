// Internal to the scene loader: the three passes of parse_scene() (docs/architecture.md, "Scene
// loading").
//   (a) describe_scene: the YAML tree (overrides applied) into a SceneDescription, every key read
//       and checked, nothing built: the top-level settings; each rod's own keys, initial state,
//       boundary and loads; contact settings, obstacles (placed as read: they depend on no rod)
//       and grasps. What needs a built rod stays unresolved: node and segment indices (IndexRef),
//       keyframes given as absolute poses (MotionDescription), a grasp's arc length.
//   (b) build_scene: the world from the description alone (no key is read): each rod built, then
//       its initial velocities, boundary, loads (indices resolved) and rotational_inertia_scale;
//       contact settings, obstacles (no rod may start inside one), grasps. Its errors are those
//       only a built rod shows (an index out of range, a rod too long or starting inside an
//       obstacle, two entries constraining one node); the description keeps each key's Value to
//       name it and its line. (One exception reads a key again: an elements: auto rod's `initial`
//       node and segment numbers, checked as integers against the built rod.)
//   (c) make_automatic_choices: on the built scene, initial_state: equilibrium, then time_step:
//       auto and integrator: auto, each logged with its reason in Scene::notes or settled. It
//       counts work, never time, so the result depends on the scene only. elements: auto runs
//       between (a) and (b): it sets the rods' counts in the description after probe builds
//       (b, c) of it at two resolutions (scene_elements.h).
// Of several errors in a file, the first in pass (a) (in file order) is reported.
#pragma once

#include <yaml-cpp/yaml.h>

#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "corde_sim/grasp/grasp.h"
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

// A `masses` entry: a point mass at a node, with a rigid body's rotary inertia at an end node (a
// plug), the node unresolved.
struct MassDescription {
  std::string path;  // "rods[0].masses[1]"
  IndexRef at;
  double mass = 0.0;                                 // kg
  double inertia_across = 0.0, inertia_along = 0.0;  // kg m^2
  std::optional<Value> inertia_key;                  // the first inertia key given
  Vec3 offset = Vec3::Zero();                        // m, end segment's material frame
  std::optional<Value> offset_key;                   // `offset`, when given
};

// A `density_ranges` entry: the density over [from, to] of rest arc length (m).
struct DensityRange {
  double from = 0.0, to = 0.0, rho = 0.0;
  Value key{YAML::Node(), ""};
};

// A `boundary` entry (scene_boundary.cpp): its node or segment unresolved, its drive's keyframes
// not yet placed at the rod's start.
struct BoundaryDescription {
  std::string path;  // "rods[0].boundary[1]"
  enum class Kind { kNode, kSegment, kClamp } kind = Kind::kNode;
  IndexRef at;  // kNode, kSegment: the node or segment (its key names it in messages)
  // kNode: fix, velocity, line, plane or motion; kSegment: fix, spin_rate, free_axis or motion.
  std::string mode;
  Vec3 direction = Vec3::Zero();  // line, plane, free_axis (not tangent), a clamp's slide axis
  bool along_tangent = false;     // free_axis: tangent, slide: true
  Vec3 velocity = Vec3::Zero();   // m/s
  double rate = 0.0;              // rad/s (spin_rate)
  double start_time = 0.0;        // s (velocity, spin_rate)
  std::optional<MotionDescription> motion;
  // kClamp: which end and how it holds.
  std::optional<Value> clamp_key;
  bool end = false, natural = false, twist_free = false, slides = false;
};

// A grasp entry (scene_grasps.cpp): its rod found by name, its node unresolved, its keyframes not
// yet placed at the held segment.
struct GraspDescription {
  std::optional<Value> entry;  // for messages naming the entry
  GraspSpec spec;              // all but value (node, arc length), motion, motion_reference
  int rod = 0;                 // index in the scene's rods
  IndexRef node;               // place: node
  std::optional<Value> arc_length_key;
  std::optional<MotionDescription> motion;
};

// A rod's own keys, read in pass (a).
struct RodDescription {
  std::string path;  // "rods[0]"
  RodSpec spec;      // name, elements, section (material, radius), shape, reference_d1, rest_shape
  // elements: auto: spec.elements is 0 until choose_elements() sets it (scene_elements.h).
  bool auto_elements = false;
  std::optional<Value> elements_key;
  std::optional<Value> shape_key;  // names the shape when the built rod's length is out of range
  std::optional<Drag> drag;
  std::optional<ContactOptions> contact;
  std::optional<Value> equilibrium;  // the initial_state key that asks for it (the rod's or the
                                     // scene's)
  std::optional<InitialDescription> initial;
  std::vector<BoundaryDescription> boundary;
  std::vector<LoadDescription> loads;
  std::vector<MassDescription> masses;
  std::vector<DensityRange> density_ranges;
  MaterialOrigin origin;  // which key each section constant follows (read_section)
  // rotational_inertia_scale: a number, or auto (computed on the built rod, noted under its key).
  std::optional<double> inertia_scale;
  std::optional<std::string> inertia_scale_auto;  // the key's path
};

// The obstacles of the scene (scene_contact.cpp): placed and keyframed as read, since they depend
// on no rod, and accepted by an ObstacleSet once; pass (b) adds them to a new set of the world
// (each build its own: a run moves them) and checks that no rod starts inside one.
struct ObstaclesDescription {
  std::vector<Obstacle> obstacles;
  std::vector<ObstacleMotion> motions;
  std::vector<std::string> paths;  // the entry ("obstacles[2]") of each obstacle
};

// Pass (a)'s result.
struct SceneDescription {
  std::string source;  // names the text in messages
  std::string base;    // folder of relative paths (keyframe files, URDFs): the scene file's
  std::string name, description;
  std::optional<Vec3> gravity;  // m/s^2; none: the world's default
  double gravity_ramp = 0.0;    // s
  Integrator integrator = kDefaultIntegrator;
  bool integrator_auto = false;
  double duration = 1.0;  // s
  Scene::Mode mode = Scene::Mode::kDynamics;
  double statics_time = 0.0;        // s
  std::optional<double> time_step;  // s; none: time_step: auto
  std::optional<Value> time_step_key;
  std::optional<double> shape_tolerance;  // given with a rod's elements: auto
  std::vector<std::string> warnings;
  std::vector<RodDescription> rods;  // at least one, at most SceneLimits::max_rods
  std::optional<ContactSettings> contact;
  std::optional<ObstaclesDescription> obstacles;
  std::vector<GraspDescription> grasps;
};

// Which entry constrains each node and segment of a rod, to reject conflicting constraints
// (pass b, where the indices are resolved).
struct Owners {
  std::map<int, std::string> node, segment;
  std::string ghost[2];

  void claim(std::map<int, std::string>* owners, int index, const char* what, const Value& v,
             const std::string& owner);
};

SceneDescription describe_scene(const YAML::Node& root, const std::string& source);
Scene build_scene(const SceneDescription& description, AutomaticRequests* requests);
// The rods' elements together within SceneLimits::max_total_elements; fails naming the elements
// key of the rod that crosses it.
void check_total_elements(const std::vector<RodDescription>& rods);

// A `boundary` entry, and its drives and constraints on the built rod, recorded as a support
// (scene_boundary.cpp).
BoundaryDescription describe_boundary(const Value& entry, const std::string& base);
void build_boundary(const BoundaryDescription& d, Rod* rod, Owners* owners, Support* support);
// A `grasps` entry, its rod looked up among `rods` by name, its name unique among `before`; and
// the grasp on the built rod, its nodes (and segment) claimed in `owners` (scene_grasps.cpp).
GraspDescription describe_grasp(const Value& v, const std::vector<RodDescription>& rods,
                                const std::vector<GraspDescription>& before,
                                const std::string& base);
GraspSpec build_grasp(const GraspDescription& d, const Rod& rod, Owners* owners);
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
