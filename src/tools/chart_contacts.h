// The contact-solve chart of corde_charts: CPU per simulated second against the number of
// contacts for the implicit contact solves (ContactSettings::Solver: the rounds and the Delassus
// solve) on the same scenes, implicit Euler at 2 ms: (a) a steel rod of N elements of 1 cm
// dropped 1 mm onto a floor (N + 1 contacts that load one stiff rod together), (b) a soft rope of
// N elements lying on a floor as a flat spiral whose turns touch, a coil that has set (rest_shape:
// created, so it stays coiled), self contact on. Library only.
#pragma once

#include <algorithm>
#include <cmath>
#include <ctime>
#include <sstream>
#include <string>

#include "corde_sim/contact/contact.h"
#include "corde_sim/scene/scene.h"

namespace corde {
namespace charts {

struct ContactPoint {
  double contacts = 0.0;        // mean contacts carrying an impulse per step
  double cpu_per_second = 0.0;  // CPU s per simulated s
  double iterations = 0.0;      // per step: rounds, or Delassus iterations
  int max_iterations = 0;
  double max_depth = 0.0;  // (a): deepest node below the floor, radii, from the positions
};

// (a) and (b) as scene text (scene 0 and 1).
inline std::string contact_chart_scene(int scene, int n) {
  std::ostringstream y;
  y.precision(9);
  y << "gravity: [0, 0, -9.81]\ntime_step: 0.002\nintegrator: implicit_euler\n"
    << "obstacles:\n  - {name: floor, type: plane, normal: [0, 0, 1], friction: 0.5}\n"
    << "contact: {friction: 0.4}\nrods:\n  - name: rod\n    elements: " << n
    << "\n    radius: 0.005\n";
  if (scene == 0) {
    y << "    material: {E: 2.0e11, nu: 0.3, rho: 7850, damping_time: 1.0e-3}\n"
      << "    shape: {type: straight, start: [0, 0, 0.006], direction: [1, 0, 0], length: "
      << 0.01 * n << "}\n";
    return y.str();
  }
  const double r = 0.005, spacing = 2.0 * r + 1e-4, a = 0.03, b = spacing / (2.0 * M_PI);
  y << "    material: {preset: nylon_rope, E: 1.0e7, E_s: 1.0e7}\n    contact: {self: true}\n"
    << "    rest_shape: created\n    shape:\n      type: polyline\n      points:\n";
  double theta = 0.0, s = 0.0;
  Vec3 prev(a, 0.0, r);
  y << "        - [" << prev.x() << ", " << prev.y() << ", " << prev.z() << "]\n";
  while (s < 0.01 * n) {
    theta += 0.002 / (a + b * theta);
    const Vec3 p((a + b * theta) * std::cos(theta), (a + b * theta) * std::sin(theta), r);
    s += (p - prev).norm();
    prev = p;
    y << "        - [" << p.x() << ", " << p.y() << ", " << p.z() << "]\n";
  }
  return y.str();
}

inline ContactPoint contact_chart_run(int scene, int n, ContactSettings::Solver solver,
                                      double duration) {
  Scene s = parse_scene(contact_chart_scene(scene, n));
  s.world.contact.implicit_solver = solver;
  const long steps = std::max(1L, std::lround(duration / s.world.time_step));
  ContactPoint p;
  double cpu = 0.0;
  long iterations = 0, contacts = 0;
  for (long k = 0; k < steps; ++k) {
    const std::clock_t c0 = std::clock();
    s.world.step();
    cpu += static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC;
    const ContactStats& st = s.world.contacts()->stats();
    const int it =
        solver == ContactSettings::Solver::kDelassus ? st.delassus_iterations : st.rounds;
    iterations += it;
    p.max_iterations = std::max(p.max_iterations, it);
    contacts += st.active;
    const Rod& rod = s.world.rods()[0];
    if (scene == 0)
      for (const Vec3& x : rod.positions())
        p.max_depth = std::max(p.max_depth, (rod.section().radius - x.z()) / rod.section().radius);
  }
  p.contacts = static_cast<double>(contacts) / static_cast<double>(steps);
  p.iterations = static_cast<double>(iterations) / static_cast<double>(steps);
  p.cpu_per_second = cpu / (static_cast<double>(steps) * s.world.time_step);
  return p;
}

}  // namespace charts
}  // namespace corde
