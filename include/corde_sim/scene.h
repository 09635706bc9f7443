// Scenes: rods, boundary conditions, loads and grasps described in YAML (docs/scene_format.md).
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

#include "corde_sim/grasp.h"
#include "corde_sim/world.h"

namespace corde {

// An invalid scene. The message starts with the path of the offending key, e.g.
// "rods[0].material.E: must be > 0, got -5".
struct SceneError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct Scene {
  World world;            // rods built, drives/loads applied, gravity, time step
  double duration = 1.0;  // s
  std::vector<GraspSpec> grasps;
  std::string name, description, source;
  // Problems that do not stop a run, e.g. a time step above the estimated stability limit.
  std::vector<std::string> warnings;
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
