// Stability map, scaling and numerical damping runs of corde_charts. Library only, no ROS.
#pragma once

#include <algorithm>
#include <cmath>
#include <complex>
#include <vector>

#include "cantilever_step.h"
#include "chart_references.h"
#include "chart_stepper.h"
#include "corde_sim/stability/explicit_step_limit.h"

namespace corde {
namespace charts {

// The stability map's rod: L = 1 m, r = 1 cm, rho = 1000, E = E_s, G = E/3, kappa = G A, clamped
// by a ghost frame, released straight under g = 9.81.
inline Rod stability_rod(double youngs, int n) {
  return fixed_start_rod(rod_material(youngs, 1000.0, 0.01), 0.01, 1.0, n, true);
}

// Stable: every state finite, every implicit step's Newton residual within 1e-3 of its
// reference scale (a step that stops short of the 1e-8 tolerance after its 20 iterations but
// near it is not an instability), and the total energy (kinetic, elastic, gravity) never above
// its start by more than 1% of the weight's potential scale m g L over `steps` steps (the run is
// undamped, so the exact energy stays constant). For the explicit methods the kinetic energy is
// taken at the step's mean velocity (v_n + v_n+1)/2 with the potential at x_n: their kick-drift
// velocities live at half steps, and with v_n+1 alone the energy of these first-order methods
// carries a bounded O(h) error which, in the collapsing E = 1e4 rod, exceeds 1% of m g L from
// 0.6 of the stable step (docs/charts.md, "Stability map"). `min_predicted`, when given, gets the
// smallest state-aware prediction (state_critical_time_step) over the run's states, every 10 steps.
inline bool stable_run(double youngs, int n, Method m, double h, long steps,
                       double* min_predicted = nullptr) {
  Rod rod = stability_rod(youngs, n);
  const Vec3 g(0.0, 0.0, -9.81);
  const double mass = rod.section().mass_per_length;  // L = 1
  auto energy = [&] {
    const Energies e = rod.energies(g);
    return e.elastic() + e.kinetic() + e.gravity;
  };
  const double e0 = energy(), tol = 0.01 * mass * 9.81;
  const bool mean_velocity = is_explicit(m);
  std::vector<Vec3> v0, w0;
  Stepper stepper(m);
  for (long i = 0; i < steps; ++i) {
    const bool check = (i + 1) % 10 == 0 || i + 1 == steps;
    double potential = 0.0;
    if (check && mean_velocity) {
      const Energies e = rod.energies(g);
      potential = e.elastic() + e.gravity;
      v0 = rod.velocities();
      w0 = rod.angular_velocities();
    }
    if (min_predicted && i % 10 == 0)
      *min_predicted = std::min(*min_predicted, state_critical_time_step(rod));
    if (!stepper.step(rod, i * h, h, g) && stepper.relative_residual() > 1e-3) return false;
    if (check) {
      if (!rod.finite()) return false;
      double e = energy();
      if (mean_velocity) {
        e = potential;
        for (int k = 0; k < rod.num_nodes(); ++k)
          e += 0.5 * rod.node_masses()[k] * (0.5 * (v0[k] + rod.velocities()[k])).squaredNorm();
        for (int k = 0; k < rod.num_segments(); ++k) {
          const Vec3 w = 0.5 * (w0[k] + rod.angular_velocities()[k]);
          e += 0.5 * w.dot(rod.segment_inertia(k).cwiseProduct(w));
        }
      }
      if (!std::isfinite(e) || e > e0 + tol) return false;
    }
  }
  return true;
}

inline Rod scaling_rod(int n) {
  return fixed_start_rod(rod_material(200e9, 7850.0, 1e-3), 1e-3, 0.025 * n, n, false);
}

struct StabilityPoint {
  // Explicit limit: for the explicit methods the smallest state-aware prediction
  // (state_critical_time_step) over the run at the measured step, for the implicit one
  // critical_time_step() of the straight rod.
  double predicted = 0.0;
  double measured = 0.0;  // largest stable step found (the cap if stable there)
  bool capped = false;    // stable at the cap
};

// Bisects in log(h) between a stable and an unstable step, `iterations` times, starting from the
// explicit prediction; `cap` bounds the search (stable at the cap: measured = cap, capped).
inline StabilityPoint stable_step(double youngs, int n, Method m, long steps, double cap,
                                  int iterations) {
  StabilityPoint p;
  p.predicted = critical_time_step(stability_rod(youngs, n));
  double lo = 0.0, hi = 0.0;
  // Explicit: start at the prediction; implicit: below the cap.
  double h = is_explicit(m) ? std::min(cap, p.predicted) : 0.5 * cap;
  if (stable_run(youngs, n, m, cap, steps)) {
    p.measured = cap;
    p.capped = true;
    return p;
  }
  hi = cap;
  // Find a stable lower bound by halving.
  while (h > 1e-4 * p.predicted) {
    if (stable_run(youngs, n, m, h, steps)) {
      lo = h;
      break;
    }
    hi = h;
    h *= 0.5;
  }
  if (lo == 0.0) return p;  // nothing stable found
  // Tighten the upper bound near the prediction before the bisection.
  for (double f : {1.1, 1.5, 3.0}) {
    const double t = lo * f;
    if (t >= hi) break;
    if (!stable_run(youngs, n, m, t, steps)) {
      hi = t;
      break;
    }
    lo = t;
  }
  for (int it = 0; it < iterations; ++it) {
    const double mid = std::sqrt(lo * hi);
    (stable_run(youngs, n, m, mid, steps) ? lo : hi) = mid;
  }
  p.measured = lo;
  // The rod collapses and crumples under its weight when soft: the prediction about its
  // straight rest state does not hold in the states it passes through.
  if (is_explicit(m)) stable_run(youngs, n, m, lo, steps, &p.predicted);
  return p;
}

// Microseconds of CPU per step of a steel cable (E = 200 GPa, rho = 7850, r = 1 mm) of N elements
// of 2.5 cm (the 40 elements per metre of the charts' cable), pinned at node 0 and released
// horizontal under gravity, at step h, over at least `min_cpu` seconds of CPU. (Elements kept at a
// fixed length: far shorter than the radius, they are not a rod any more.)
inline double us_per_step(Method m, int n, double h, double min_cpu, double* newton_per_step) {
  Rod rod = scaling_rod(n);
  Stepper stepper(m);
  const Vec3 g(0.0, 0.0, -9.81);
  long steps = 0;
  const double start = cpu_seconds();
  double used = 0.0;
  while (used < min_cpu || steps < 3) {
    stepper.step(rod, steps * h, h, g);
    ++steps;
    used = cpu_seconds() - start;
  }
  *newton_per_step = static_cast<double>(stepper.newton_iterations()) / steps;
  return used / steps * 1e6;
}

struct DampingPoint {
  double omega = 0.0;            // the mode's angular frequency (Timoshenko series, rad/s)
  double factor_per_step = 0.0;  // measured amplitude factor per step
  // backward Euler: 1/sqrt(1 + (h omega)^2); BDF2: |r| of the principal root of
  // (3/2 - i h omega) r^2 - 2 r + 1/2 = 0
  double theory_per_step = 0.0;
  long steps = 0;
};

// Numerical damping of bending mode `mode` (1-based) of the example rod clamped by a ghost frame,
// no gravity: started at rest in the Euler-Bernoulli mode shape (tip amplitude 1e-4 L), run for
// two periods (at least 4 steps, stopping once the energy fell below 1e-8 of its start). With a
// single mode, elastic + kinetic energy is |z|^2 of the mode's oscillator, so the amplitude factor
// per step is (E_end/E_0)^(1/(2 steps)). BDF2 starts with a backward Euler step and has a
// parasitic root (|r| about 1/3): its energy is measured from the end of a first period (at
// least 10 steps) to two periods later (at least 20 steps).
inline double bdf2_amplitude_factor(double hw) {
  const std::complex<double> a(1.5, -hw), b(-2.0, 0.0), c(0.5, 0.0);
  const std::complex<double> d = std::sqrt(b * b - 4.0 * a * c);
  return std::max(std::abs((-b + d) / (2.0 * a)), std::abs((-b - d) / (2.0 * a)));
}

inline DampingPoint mode_damping(Method m, int n, int mode, double h_omega) {
  Rod rod = fixed_start_rod(rod_material(1e7, 1000.0, 0.01), 0.01, 1.0, n, true);
  const Section& s = rod.section();
  const v8::ModalSeries series(
      v8::Timoshenko{s.bend, s.kappa, s.mass_per_length, s.inertia_bend, 1.0}, mode);
  DampingPoint p;
  p.omega = series.omega(mode - 1);
  const double h = h_omega / p.omega;
  const double beta = v8::clamped_free_betas(mode).back();
  for (int i = 0; i <= n; ++i) {
    Vec3& x = rod.positions()[i];
    x.z() = 0.5e-4 * clamped_free_mode(beta, x.x());
  }
  align_frames_to_chords(&rod);
  auto energy = [&] {
    const Energies e = rod.energies(Vec3::Zero());
    return e.elastic() + e.kinetic();
  };
  const bool bdf2 = m == Method::kBdf2;
  const double theory =
      bdf2 ? bdf2_amplitude_factor(h_omega) : 1.0 / std::sqrt(1.0 + h_omega * h_omega);
  // (a heavily damped mode: a start-up short enough to leave 1e-6 of the energy to measure)
  const long skip = bdf2 ? std::min(std::max(10L, std::lround(2.0 * kPi / h_omega)),
                                    std::max(2L, static_cast<long>(-3.0 / std::log10(theory))))
                         : 0;
  const long steps = skip + std::max(bdf2 ? 20L : 4L, std::lround(2.0 * 2.0 * kPi / h_omega));
  Stepper stepper(m);
  double e0 = energy(), e = e0;
  long i = 0;
  while (i < steps && e > 1e-8 * e0) {
    stepper.step(rod, i * h, h, Vec3::Zero());
    ++i;
    e = energy();
    if (i == skip) e0 = e;
  }
  p.steps = std::max(1L, i - skip);
  p.factor_per_step = std::pow(e / e0, 0.5 / p.steps);
  p.theory_per_step = theory;
  return p;
}

}  // namespace charts
}  // namespace corde
