// Statics as a mode: the static equilibrium of a scene's rods, solved directly (statics.h) for
// users who want where a cable settles (its sag, what its supports carry) rather than its motion;
// also the `initial_state: equilibrium` start of a dynamic run (docs/validation_static.md,
// "Statics as a mode").
#pragma once

#include <string>
#include <vector>

#include "corde_sim/scene/scene.h"
#include "corde_sim/statics/static_sensitivity.h"
#include "corde_sim/statics/statics.h"

namespace corde {

struct RodEquilibrium {
  std::string rod;
  StaticResult result;  // of the last attempt
  int attempts = 0;     // solves tried: each failure retries with 4x the load steps
  // Stability: the numbers of negative and of numerically zero eigenvalues of the potential
  // energy's Hessian at the solution (Sylvester's inertia of its LDL^T). Negative: unstable (e.g.
  // a column beyond buckling), a dynamic run leaves it. Zero: neutral directions (a rod free to
  // turn about a pin). -1: the factorisation could not tell.
  int negative_modes = 0, zero_modes = 0;
  // False when dead torques act: they have no potential, so the Hessian's signs do not tell
  // stability (a rod bent far by an end moment shows negative ones at rest); not judged then.
  bool potential = true;
  // The lowest node, and the sag: how far it hangs below the lowest held node (m, >= 0 when it
  // hangs; NaN for a rod held by no node).
  int lowest_node = 0;
  double lowest_z = 0.0, support_z = 0.0, sag = 0.0;
};

struct SceneEquilibrium {
  bool ok = true;       // every rod converged
  std::string problem;  // why not, naming the rod
  double time = 0.0;    // the drives' and grasps' time
  double wall_seconds = 0.0;
  std::vector<RodEquilibrium> rods;
};

// "" when statics can solve the rod (all rods for an empty name), else what it cannot handle and
// why, naming the rod and item: follower loads (no potential), line/plane/axis constraints,
// obstacle, rod-rod or self contacts (statics solves no contacts), a rod held nowhere under
// gravity or loads at time t (no equilibrium; a grasp holds at t from its grasp_time to before its
// release_time).
std::string statics_unsupported(const Scene& scene, const std::string& rod = "", double t = 0.0);

// Solves every rod's equilibrium at time t: drives at their state at t, the grasps that hold at t
// where their keyframes put them then (or where they take hold; a late grasp's holder starts at
// the segment's pose as given, statics does not follow the motion before it), loads that have
// started by t at their full value (ramps completed: a ramp only keeps a dynamic run from ringing).
// From the rods' current state, with continuation: a failed solve is retried from that state with
// 4x the load steps (up to 4 attempts). Sets the world's time to t, zeroes the velocities and
// records each support's static reaction (reactions.h). Throws SceneError when
// statics_unsupported().
SceneEquilibrium solve_scene_statics(Scene* scene, double t, const StaticOptions& options = {});

// `initial_state: equilibrium`: puts the rod at its equilibrium at time 0, at rest, with the
// scene's grasps held where they take hold and the loads as the run starts with them (a ramp
// from zero: none), so that the run starts in equilibrium; its drives are left as they were. Throws
// SceneError when statics cannot handle the rod or does not converge.
RodEquilibrium settle_rod(Scene* scene, Rod* rod);

// The material parameters statics_sensitivity() knows: E, G, E_s, B, C, K_s, kappa and rho
// (density an alias of rho), the scene's material keys.
const std::vector<std::string>& sensitivity_parameters();

// The sensitivity of rod `rod`'s equilibrium at time t to the material keys `parameters`
// (static_sensitivity.h): per parameter d(node positions)/dp and the segments' body rotations per
// unit of p. The rod must be at the equilibrium solve_scene_statics(scene, t) left (not checked);
// loads that have started act whole and gravity at its full value, as that solve put them. A key
// changes the section constants the scene derived from it (Scene::materials): E bending and, unless
// E_s or K_s is given, stretch (and with nu twist and a default kappa); G twist and a default
// kappa (G A); rho the rod's distributed mass (point masses stay). Throws SceneError for an
// unknown rod or parameter, a key the rod's material does not derive anything from (e.g. E where
// it gives B), rho with density ranges, or a singular Hessian.
std::vector<StaticSensitivity> scene_statics_sensitivity(
    Scene* scene, const std::string& rod, double t, const std::vector<std::string>& parameters);

// Multiline report: per rod converged or not, residual, Newton iterations, load steps, stability,
// lowest node and sag; per support its force and moment.
std::string statics_summary(const Scene& scene, const SceneEquilibrium& eq);

}  // namespace corde
