// Shared by the scene input tests: a small valid scene to vary, and the message a scene fails with.
#pragma once

#include <string>
#include <vector>

#include "corde_sim/scene/scene.h"

namespace corde {
namespace test {

// A 0.2 m soft cable of 4 elements clamped at its start: valid, and quick to load and run.
inline const char* kClampedCable = R"(time_step: 1.0e-5
duration: 0.002
rods:
  - name: cable
    elements: 4
    material: {preset: soft_cable, gamma_t: 0.2}
    shape: {type: straight, start: [0, 0, 1], direction: [1, 0, 0], length: 0.2}
    boundary:
      - {clamp: start}
)";

// The message of the exception parse_scene() throws: a SceneError's as is, any other exception's
// marked "NOT A SceneError: " ("" when it throws nothing).
inline std::string scene_error_of(const std::string& yaml,
                                  const std::vector<std::string>& overrides = {}) {
  try {
    parse_scene(yaml, overrides);
  } catch (const SceneError& e) {
    return e.what();
  } catch (const std::exception& e) {
    return std::string("NOT A SceneError: ") + e.what();
  }
  return "";
}

}  // namespace test
}  // namespace corde
