// Bounds on the values a scene may give (docs/scene_format.md, "Limits"): each alone is finite,
// but products of finite values overflow (a fluid density of 1e308 times a drag coefficient of
// 10), and absurd sizes break the geometry queries (a box of 1e308 m). Within these bounds every
// product the model forms stays finite; a value outside them is a SceneError naming its key.
#pragma once

#include "corde_sim/scene/scene.h"

namespace corde {

struct SceneBounds {
  // m: coordinates of positions and points, sizes, radii, rod lengths, displacements.
  static constexpr double max_length = SceneLimits::max_length;
  // m: the smallest rod radius and rod length (a segment of 1e-300 m has stiffnesses that
  // overflow).
  static constexpr double min_length = 1.0e-6;
  // m: an obstacle as placed, position or size (a URDF link's pose is its base's times its
  // chain's, each within max_length).
  static constexpr double max_placed_length = 10.0 * max_length;
  static constexpr double max_speed = 1.0e4;          // m/s: velocities (each component)
  static constexpr double max_angular_speed = 1.0e6;  // rad/s: spins and spin rates
  static constexpr double max_acceleration = 1.0e4;   // m/s^2: gravity (about 1000 g)
  static constexpr double max_force = 1.0e12;         // N: loads (each component)
  static constexpr double max_torque = 1.0e12;        // N m
  static constexpr double max_mass = 1.0e6;           // kg: point masses at nodes
  static constexpr double max_inertia = 1.0e6;        // kg m^2: a body's rotary inertia
  // Pa: E, G, E_s. Far beyond any material (diamond: 1.2e12 Pa), as the guard's tests use
  // impossible stiffnesses; with radii within max_length their products stay finite.
  static constexpr double max_modulus = 1.0e30;
  static constexpr double max_density = 1.0e5;   // kg/m^3: rho, fluid_density
  static constexpr double min_density = 1.0e-2;  // kg/m^3: rho
  // Stiffnesses and damping coefficients given directly (B, C, K_s, kappa, gamma_t, gamma_r) and
  // drag coefficients (linear_*, quadratic_*), in their SI units.
  static constexpr double max_coefficient = 1.0e30;
  // Dimensionless factors: friction and drag coefficients, max_strain, turns,
  // rotational_inertia_scale.
  static constexpr double max_factor = 1.0e6;
  // The contact skin, a fraction of the radius: beyond it every obstacle is a candidate always.
  static constexpr double max_skin = 100.0;
  static constexpr double max_time = 1.0e9;  // s: durations, times, ramp and damping times
  // s: the shortest ramp_time and the shortest interval between keyframes (a move of 1e4 m in
  // 1e-300 s has an infinite speed).
  static constexpr double min_time_interval = 1.0e-9;
};

}  // namespace corde
