// Scenes shared by the friction tests (surface friction, rolling resistance): a straight rope lying
// on a floor, set spinning and moving sideways, with its mean motion; and two rods crossing,
// spinning and sliding over each other without gravity, with their angular momentum and its
// round-off scale.
#pragma once

#include <cstdio>
#include <string>

#include "corde_sim/scene/scene.h"
#include "corde_sim/world/world.h"

namespace corde {
namespace friction {

// A straight 0.5 m rope of 20 elements, radius r, along x lying on a floor (friction floor_mu),
// every segment spinning at w0 about its own axis (d3) and the nodes moving sideways at vy.
// contact: the scene's contact map, e.g. "{surface_friction: true}".
inline Scene lying_rope(double r, double floor_mu, const std::string& contact,
                        const char* integrator, const char* step, double w0, double vy) {
  char buf[900];
  std::snprintf(buf, sizeof buf,
                "gravity: [0, 0, -9.81]\ntime_step: %s\n"
                "integrator: %s\n"
                "obstacles:\n  - {name: floor, type: plane, normal: [0, 0, 1], friction: %.17g}\n"
                "contact: %s\n"
                "rods:\n  - name: rope\n    elements: 20\n    radius: %.17g\n"
                "    material: {E: 1.0e6, nu: 0.5, rho: 1000, damping_time: 1.0e-3}\n"
                "    shape: {type: straight, start: [0, 0, %.17g], direction: [1, 0, 0], "
                "length: 0.5}\n",
                step, integrator, floor_mu, contact.c_str(), r, r);
  Scene s = parse_scene(buf);
  for (Vec3& w : s.world.rods()[0].angular_velocities()) w = Vec3(0.0, 0.0, w0);
  for (Vec3& v : s.world.rods()[0].velocities()) v = Vec3(0.0, vy, 0.0);
  return s;
}

// Mean sideways node velocity (y) and mean spin about the axis (world x) of the rope.
inline void rope_motion(const Rod& rod, double* vy, double* spin) {
  *vy = 0.0;
  *spin = 0.0;
  for (const Vec3& v : rod.velocities()) *vy += v.y() / rod.num_nodes();
  for (int s = 0; s < rod.num_segments(); ++s)
    *spin += (rod.orientations()[s] * rod.angular_velocities()[s]).x() / rod.num_segments();
}

// Two rods of 10 elements (r = 5 mm, 0.2 m) crossing, touching, without gravity or obstacles: b
// comes down on a and slides along it, a spins at 40 rad/s and b at -25 rad/s about their axes.
// contact: the scene's contact map.
inline Scene crossing_rods(const std::string& contact) {
  const double r = 0.005;
  char buf[1200];
  std::snprintf(buf, sizeof buf,
                "gravity: [0, 0, 0]\ntime_step: 2.0e-5\n"
                "contact: %s\n"
                "rods:\n"
                "  - name: a\n    elements: 10\n    radius: %.17g\n"
                "    material: {E: 1.0e6, nu: 0.5, rho: 1000, damping_time: 1.0e-3}\n"
                "    contact: {rods: true}\n"
                "    shape: {type: straight, start: [-0.1, 0.013, 0], direction: [1, 0, 0], "
                "length: 0.2}\n"
                "  - name: b\n    elements: 10\n    radius: %.17g\n"
                "    material: {E: 1.0e6, nu: 0.5, rho: 1000, damping_time: 1.0e-3}\n"
                "    contact: {rods: true}\n"
                "    shape: {type: straight, start: [0.011, -0.1, %.17g], direction: [0, 1, 0], "
                "length: 0.2}\n",
                contact.c_str(), r, r, 2.0 * r + 1e-5);
  Scene s = parse_scene(buf);
  Rod& a = s.world.rods()[0];
  Rod& b = s.world.rods()[1];
  for (Vec3& v : b.velocities()) v = Vec3(0.3, 0.05, -0.2);
  for (Vec3& w : a.angular_velocities()) w = Vec3(0.0, 0.0, 40.0);
  for (Vec3& w : b.angular_velocities()) w = Vec3(0.0, 0.0, -25.0);
  return s;
}

// The total angular momentum of the world's rods.
inline Vec3 angular_momentum(const World& world) {
  Vec3 l = Vec3::Zero();
  for (const Rod& rod : world.rods()) l += rod.angular_momentum();
  return l;
}

// The scale of the terms the angular momentum sums (round-off is relative to it): the nodes'
// m |x| times a speed of 0.4 m/s.
inline double angular_momentum_scale(const World& world) {
  double scale = 0.0;
  for (const Rod& rod : world.rods())
    for (int i = 0; i < rod.num_nodes(); ++i)
      scale += rod.node_masses()[i] * rod.positions()[i].norm() * 0.4;
  return scale;
}

}  // namespace friction
}  // namespace corde
