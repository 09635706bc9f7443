// Internal to the scene loader: `elements: auto`, the fewest elements per rod whose estimated
// discretisation error meets the scene's `shape_tolerance` (docs/scene_format.md).
#pragma once

#include <yaml-cpp/yaml.h>

#include <functional>
#include <string>
#include <vector>

#include "corde_sim/scene/scene.h"

namespace corde {
namespace scene_detail {

// Accepted shape tolerances (fractions of a rod's length) and the default.
constexpr double kMinShapeTolerance = 1e-5, kMaxShapeTolerance = 0.1;
constexpr double kDefaultShapeTolerance = 1e-3;
// Probe resolutions: pairs (N/2, N) with N a power of two from 16 up to this.
constexpr int kMaxProbeElements = 128;

struct SceneDescription;

// Builds a scene from a description whose rods all have their counts (passes b and c).
using SceneBuilder = std::function<Scene(const SceneDescription&)>;

// True if some rods[i].elements is "auto".
bool has_auto_elements(const YAML::Node& root);

// Sets the count of every rod of *d described with `elements: auto` (none: returns at once), from
// the description's shape_tolerance (default kDefaultShapeTolerance). Each choice comes from probe
// runs of the scene at N/2 and N elements for the auto rods (same
// step and integrator for both, over the scene's duration or as much of it as 1e7 element-steps
// allow): their largest shape difference d at
// equal material coordinates and equal times estimates the error at N as d / (2^p - 1), with the
// order p that the validation suite measured (2; 1 where a segment is held or driven: natural
// clamps, spin drives, orientation-holding grasps). The count is N (e / tol)^(1/p), probed again
// closer to it while the estimate lies beyond N (up to kMaxProbeElements). Returns one line per
// auto rod saying what was chosen and why. Throws SceneError naming the key for a numeric node or
// segment index on an auto rod (it would mean another place at every resolution), a probe run that
// fails, or counts beyond SceneLimits::max_total_elements. (describe_scene checks the tolerance.)
std::vector<std::string> choose_elements(SceneDescription* d, const SceneBuilder& build);

}  // namespace scene_detail
}  // namespace corde
