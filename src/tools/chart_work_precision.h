// Work-precision runs of corde_charts: error against CPU per 2 ms of simulated time for one
// method, N and h on (a) the cantilever sagging under its own weight (docs/peers.md's test),
// (b) the suddenly loaded cantilever of V8 (cantilever_step.h) and (c) a steel cable swinging
// under gravity against a converged run. Library only, no ROS.
#pragma once

#include <algorithm>
#include <cmath>
#include <vector>

#include "cantilever_step.h"
#include "chart_references.h"
#include "chart_stepper.h"
#include "corde_sim/stability/explicit_step_limit.h"
#include "corde_sim/statics/statics.h"

namespace corde {
namespace charts {

struct WorkPoint {
  double h = 0.0;
  double cpu_per_frame_us = 0.0;  // CPU per 2 ms of simulated time
  double error = 0.0;             // the scene's error measure (INFINITY: blew up)
  double newton_per_step = 0.0;   // implicit only
  long failures = 0;              // implicit steps that did not converge
};

// Steps `rod` from t = 0 for `duration` (whole steps of h); returns CPU per 2 ms frame and calls
// sample(t) every `every` steps (sampling is not timed).
template <class Sample>
WorkPoint timed_run(Rod& rod, Method m, double h, double duration, const Vec3& g, long every,
                    Sample&& sample) {
  Stepper stepper(m);
  const long steps = std::max(1L, std::lround(duration / h));
  double cpu = 0.0;
  WorkPoint p;
  p.h = h;
  for (long i = 0; i < steps;) {
    const long stop = std::min(steps, i + every);
    const double start = cpu_seconds();
    for (; i < stop; ++i) stepper.step(rod, i * h, h, g);
    cpu += cpu_seconds() - start;
    if (!rod.finite()) break;
    sample(i * h);
  }
  p.cpu_per_frame_us = cpu / (steps * h) * 2e-3 * 1e6;
  p.newton_per_step = static_cast<double>(stepper.newton_iterations()) / steps;
  p.failures = stepper.newton_failures();
  if (!rod.finite()) p.error = INFINITY;
  return p;
}

// (a) The peers' sagging cantilever: example rod (L = 1, r = 1 cm, rho = 1000, E = E_s = 1e7,
// G = E/3, kappa = G A), ghost clamp, gravity scaled to w = rho A g L^3/B = 5.
// The rods of kSplitRotationScaled get rotational_inertia_scale: auto (after their supports).
inline Rod for_method(Rod rod, Method m) {
  if (m == Method::kSplitRotationScaled)
    rod.set_rotational_inertia_scale(lifting_inertia_scale(rod));
  return rod;
}

struct SagScene {
  static constexpr double kW = 5.0, kRadius = 0.01, kYoungs = 1e7, kDensity = 1000.0;
  static Rod rod(int n, Method m = Method::kSplitRotation) {
    return for_method(
        fixed_start_rod(rod_material(kYoungs, kDensity, kRadius), kRadius, 1.0, n, true), m);
  }
  static Vec3 gravity(const Rod& r) {
    const Section& s = r.section();
    return Vec3(0.0, 0.0, -kW * s.bend / s.mass_per_length);
  }
  // Tip of the continuum model (bending, stretch and shear as the rod has them).
  static SagElastica::Tip reference() {
    const Rod r = rod(2);
    const Section& s = r.section();
    return SagElastica{s.bend, s.stretch, s.kappa, kW * s.bend, 1.0}.solve();
  }
};

// Error: the tip's distance from the reference at the discrete equilibrium (solve_statics on the
// same rod: at rest with zero forces, the rest state of every method's step) over L. CPU: stepping
// the rod released straight under the load for `duration`, the sag's first motion (the Newton
// iterations are highest there).
// The CPU is the median of `repeats` runs: a run of the coarse rods takes well under a
// millisecond, where the shared machine's noise is largest.
inline WorkPoint sag_point(Method m, int n, double h, double duration, const SagElastica::Tip& ref,
                           int repeats = 1) {
  const Rod start = SagScene::rod(n, m);
  const Vec3 g = SagScene::gravity(start);
  WorkPoint p;
  std::vector<double> cpu;
  for (int k = 0; k < std::max(1, repeats); ++k) {
    Rod rod = start;
    p = timed_run(rod, m, h, duration, g, 1 << 30, [](double) {});
    cpu.push_back(p.cpu_per_frame_us);
    if (!std::isfinite(p.error)) return p;
  }
  std::sort(cpu.begin(), cpu.end());
  p.cpu_per_frame_us = cpu[cpu.size() / 2];
  Rod eq = SagScene::rod(n);
  StaticOptions opt;
  opt.load_steps = 5;
  opt.plane_normal = Vec3::UnitY();
  solve_statics(eq, g, 0.0, opt);
  const Vec3 tip = eq.positions().back();
  p.error = std::hypot(tip.x() - ref.x, tip.z() - ref.z);
  return p;
}

// (b) V8 through cantilever_step.h: RMS tip error / static deflection against the Timoshenko
// series (the model's continuum limit) over `periods` periods of mode 1.
inline WorkPoint v8_point(Method m, int n, double h, double periods) {
  v8::StepCase c;
  c.elements = n;
  c.ghost_clamp = true;
  c.method = m;
  c.h = h;
  c.periods = periods;
  const v8::StepResult r = v8::run_step_case(c);
  WorkPoint p;
  p.h = r.h;
  p.cpu_per_frame_us = r.cpu_seconds / r.simulated_seconds * 2e-3 * 1e6;
  p.error = r.error_rms_timoshenko;
  p.failures = r.newton_failures;
  p.newton_per_step = static_cast<double>(r.newton_iterations) / std::max(1L, r.steps);
  return p;
}

// (c) Steel cable: E = 200 GPa, rho = 7850, r = 1 mm, L = 1 m, G = E/3, kappa = G A, pinned at
// node 0, released horizontal under g = 9.81. Error: RMS over 10 ms frames of the tip's distance
// from the reference run's tip, over L.
struct CableScene {
  static constexpr double kYoungs = 200e9, kDensity = 7850.0, kRadius = 1e-3;
  static Rod rod(int n, Method m = Method::kSplitRotation) {
    return for_method(
        fixed_start_rod(rod_material(kYoungs, kDensity, kRadius), kRadius, 1.0, n, false), m);
  }
};

constexpr double kCableFrame = 0.01;  // s between compared tip samples

inline std::vector<Vec3> cable_tips(Method m, int n, double h, double duration, WorkPoint* p) {
  Rod rod = CableScene::rod(n, m);
  std::vector<Vec3> tips;
  const long every = std::max(1L, std::lround(kCableFrame / h));
  *p = timed_run(rod, m, h, duration, Vec3(0, 0, -9.81), every,
                 [&](double) { tips.push_back(rod.positions().back()); });
  return tips;
}

inline double tip_history_error(const std::vector<Vec3>& a, const std::vector<Vec3>& ref) {
  if (a.size() != ref.size() || a.empty()) return INFINITY;
  double sum = 0.0;
  for (size_t k = 0; k < a.size(); ++k) sum += (a[k] - ref[k]).squaredNorm();
  return std::sqrt(sum / a.size());
}

}  // namespace charts
}  // namespace corde
