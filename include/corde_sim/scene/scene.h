// Scenes: rods, boundary conditions, loads and grasps described in YAML (docs/scene_format.md).
#pragma once

#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "corde_sim/grasp/grasp.h"
#include "corde_sim/grasp/reactions.h"
#include "corde_sim/world/world.h"

namespace corde {

// An invalid scene. The message starts with the path of the offending key, e.g.
// "rods[0].material.E: must be > 0, got -5".
struct SceneError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// Limits on what a scene may ask for (docs/scene_format.md, "Limits"), so that a typo or a
// hostile file gives a clear error instead of a run that never ends or exhausts memory.
struct SceneLimits {
  static constexpr long max_file_bytes = 1 << 20;     // scene file size (1 MiB)
  static constexpr int max_rods = 1000;               // rods in a scene
  static constexpr int max_elements = 100000;         // elements of one rod
  static constexpr long max_total_elements = 200000;  // elements of all rods together
  static constexpr int max_items = 10000;             // loads or boundary entries of a rod
  static constexpr int max_grasps = 1000;             // grasps in a scene
  // Files a scene refers to, and geometry (URDFs, meshes, obstacles): bounded so that a hostile or
  // mistaken file is refused with a message instead of exhausting memory or the stack.
  static constexpr long max_keyframe_file_bytes = 1 << 20;  // keyframe CSV (1 MiB)
  static constexpr long max_urdf_bytes = 16L << 20;         // URDF text (16 MiB)
  static constexpr int max_urdf_links = 100000;             // links of one URDF
  static constexpr long max_mesh_bytes = 64L << 20;         // one mesh file (64 MiB)
  static constexpr long max_mesh_triangles = 1000000;       // triangles of one mesh
  static constexpr long max_mesh_vertices = 3000000;        // vertices of one mesh
  static constexpr double max_length = 1.0e4;               // m: any size, position or extent
};

// Which material key each of a rod's section constants is proportional to, as the scene derived
// them (docs/scene_format.md, the material map): "E", "G", "E_s", "B", "C", "K_s", "kappa", "rho";
// "" for none (the mass with density ranges, which keep their own densities). With nu, the twist
// and a default kappa follow E. statics' sensitivity (statics/scene_statics.h) reads it.
struct MaterialOrigin {
  std::string bend = "E", twist = "G", stretch = "E", kappa = "G", mass = "rho";
  // The keys' values (Pa, N m^2, N or kg/m^3) the section was derived from, by key.
  std::vector<std::pair<std::string, double>> values;
};

struct Scene {
  World world;            // rods built, drives/loads applied, gravity, time step
  double duration = 1.0;  // s
  std::vector<GraspSpec> grasps;
  // Every boundary entry of every rod (clamps, drives, constraints), for their reactions; grasps
  // are supports too (corde_run adds them when it takes hold).
  std::vector<Support> supports;
  std::string name, description, source;
  // Problems that do not stop a run, e.g. a time step above the estimated stability limit.
  std::vector<std::string> warnings;
  // What corde_run does with the scene (top-level `mode`): run it, or solve its static
  // equilibrium with the drives and grasps at `statics_time` (statics/scene_statics.h). The ROS
  // node always runs it.
  enum class Mode { kDynamics, kStatics };
  Mode mode = Mode::kDynamics;
  double statics_time = 0.0;  // s
  // Rods started from their static equilibrium (`initial_state: equilibrium`), one line each:
  // residual, Newton iterations, load steps.
  std::vector<std::string> settled;
  // Choices the loader made for the scene and why (elements: auto, integrator: auto, time_step:
  // auto), one line each, for corde_run's summary and the node's log.
  std::vector<std::string> notes;
  // Per rod of world.rods(), how its section follows the material keys.
  std::vector<MaterialOrigin> materials;
};

// Parses and validates a scene. `overrides` are "key.path=value" strings (e.g.
// "rods.0.elements=100", "rods.cable.radius=0.004", "gravity=[0,0,-1]"; list items may be named
// by index or, for rods and grasps, by name) applied to the YAML tree before validation; the value
// is parsed as YAML. Throws SceneError. `source` names the text in messages.
Scene parse_scene(const std::string& yaml_text, const std::vector<std::string>& overrides = {},
                  const std::string& source = "<string>");

// Reads the file and parses it; a missing or unreadable file is a SceneError too.
Scene load_scene(const std::string& path, const std::vector<std::string>& overrides = {});

}  // namespace corde
