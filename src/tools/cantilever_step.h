// V8 (docs/validation_references.md): the suddenly loaded undamped cantilever and its exact modal
// series, the core of corde_accuracy (accuracy against cost) and of its unit test. Library only,
// no ROS.
//
// Tip history w(t)/delta = 1 - sum_n c_n cos(omega_n t), delta = P L^3/(3B), c_n = 12/(beta_n L)^4,
// with beta_n L the roots of cos(b) cosh(b) = -1 (Euler-Bernoulli). The rod's continuum limit is
// a Timoshenko beam (shear stiffness kappa, rotary inertia), whose frequencies are slightly lower,
// so the error against this series has a floor that no N or h removes (docs/validation_dynamic.md).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <ctime>
#include <vector>

#include "chart_stepper.h"
#include "corde_sim/rod/material.h"
#include "corde_sim/rod/rod.h"
#include "corde_sim/rod/rod_shape.h"
#include "corde_sim/stability/explicit_step_limit.h"

namespace corde {
namespace v8 {

constexpr double kPi = 3.14159265358979323846;

struct StepCase {
  int elements = 20;
  double step_fraction = 0.9;  // h = step_fraction * critical_time_step(rod)
  bool ghost_clamp = true;     // false: node 0 and segment 0 fixed (the natural clamp)
  double periods = 5.0;        // length of the compared history in periods of mode 1
  double alpha = 0.01;         // P L^2 / B
  charts::Method method = charts::Method::kSplitRotation;
  double h = 0.0;  // > 0: this step (s) instead of step_fraction of the critical one
};

struct StepResult {
  double h = 0.0;                     // time step (s)
  long steps = 0;                     // steps simulated
  double error_rms = 0.0;             // RMS of (w - w_ref)/delta over the history
  double error_max = 0.0;             // max |w - w_ref|/delta
  double error_rms_timoshenko = 0.0;  // RMS against the Timoshenko series (the model's limit)
  double delta = 0.0;                 // static tip deflection P L^3/(3B) (m)
  double cpu_seconds = 0.0;           // CPU of the stepping loop
  double simulated_seconds = 0.0;
  bool finite = true;
  long newton_failures = 0;    // implicit steps whose Newton iteration did not converge
  long newton_iterations = 0;  // over all steps (implicit only)
};

// The first `count` roots of cos(b) cosh(b) + 1 = 0, written cos(b) + 1/cosh(b) = 0 so that
// large b do not overflow.
inline std::vector<double> clamped_free_betas(int count) {
  std::vector<double> beta;
  for (int n = 1; n <= count; ++n) {
    double b = n == 1 ? 1.8751 : n == 2 ? 4.6941 : (n - 0.5) * kPi;
    for (int it = 0; it < 50; ++it) {
      const double f = std::cos(b) + 1.0 / std::cosh(b);
      const double df = -std::sin(b) - std::tanh(b) / std::cosh(b);
      const double step = f / df;
      b -= step;
      if (std::abs(step) < 1e-15 * b) break;
    }
    beta.push_back(b);
  }
  return beta;
}

// Timoshenko beam (bending B, shear kappa, mass mu and rotary inertia rho_i per length), one
// harmonic solution at omega^2 = w2 with state (w, psi, M, V): w' = psi + V/kappa, psi' = M/B,
// M' = -V - rho_i w2 psi, V' = -mu w2 w. Starts clamped (w = psi = 0) with (M, V) = (m0, v0);
// RK4 over the length. If `energy` is given it receives the modal mass int(mu w^2 + rho_i psi^2).
struct Timoshenko {
  double bend, kappa, mu, rho_i, length;
  int steps = 2000;
  using State = std::array<double, 4>;
  State rhs(const State& y, double w2) const {
    return {y[1] + y[3] / kappa, y[2] / bend, -y[3] - rho_i * w2 * y[1], -mu * w2 * y[0]};
  }
  State shoot(double w2, double m0, double v0, double* modal_mass = nullptr) const {
    State y{0.0, 0.0, m0, v0};
    const double dx = length / steps;
    double mass = 0.0;
    auto density = [&](const State& s) { return mu * s[0] * s[0] + rho_i * s[1] * s[1]; };
    for (int i = 0; i < steps; ++i) {
      const double before = density(y);
      State k1 = rhs(y, w2), y2, y3, y4;
      for (int j = 0; j < 4; ++j) y2[j] = y[j] + 0.5 * dx * k1[j];
      const State k2 = rhs(y2, w2);
      for (int j = 0; j < 4; ++j) y3[j] = y[j] + 0.5 * dx * k2[j];
      const State k3 = rhs(y3, w2);
      for (int j = 0; j < 4; ++j) y4[j] = y[j] + dx * k3[j];
      const State k4 = rhs(y4, w2);
      for (int j = 0; j < 4; ++j) y[j] += dx / 6.0 * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j]);
      mass += 0.5 * dx * (before + density(y));
    }
    if (modal_mass) *modal_mass = mass;
    return y;
  }
  // Free end: M(L) = V(L) = 0 for some (m0, v0) != 0.
  double free_end_determinant(double omega) const {
    const State a = shoot(omega * omega, 1.0, 0.0), b = shoot(omega * omega, 0.0, 1.0);
    return a[2] * b[3] - a[3] * b[2];
  }
};

// w_tip(t)/delta for a tip step load P: a static part minus sum_n c_n cos(omega_n t). The
// Euler-Bernoulli series has static part 1 and c_n = 12/(beta_n L)^4. The Timoshenko series
// (the rod's continuum limit) has static part 1 + 3B/(kappa L^2), and for its first modes
// c_n = phi_n(L)^2 / (m_n omega_n^2) * P/delta from the shooting solution; higher modes keep
// the Euler-Bernoulli terms (c_n < 1e-4 there).
class ModalSeries {
 public:
  // Euler-Bernoulli, `modes` terms.
  ModalSeries(double bend, double mass_per_length, double length, int modes = 30) {
    const double scale = std::sqrt(bend / (mass_per_length * std::pow(length, 4)));
    for (double b : clamped_free_betas(modes)) {
      omega_.push_back(b * b * scale);
      coeff_.push_back(12.0 / std::pow(b, 4));
    }
  }
  // Timoshenko for the first `exact_modes` modes.
  ModalSeries(const Timoshenko& beam, int exact_modes, int modes = 30)
      : ModalSeries(beam.bend, beam.mu, beam.length, modes) {
    const double delta_per_load = std::pow(beam.length, 3) / (3.0 * beam.bend);
    static_part_ = 1.0 + 3.0 * beam.bend / (beam.kappa * beam.length * beam.length);
    for (int n = 0; n < exact_modes && n < modes; ++n) {
      // The Timoshenko root lies a little below the Euler-Bernoulli one; bisect a bracket.
      double lo = 0.95 * omega_[n], hi = 1.0005 * omega_[n];
      const double f_lo = beam.free_end_determinant(lo);
      for (int it = 0; it < 60; ++it) {
        const double mid = 0.5 * (lo + hi);
        ((beam.free_end_determinant(mid) > 0.0) == (f_lo > 0.0) ? lo : hi) = mid;
      }
      const double w = 0.5 * (lo + hi), w2 = w * w;
      const Timoshenko::State a = beam.shoot(w2, 1.0, 0.0), b = beam.shoot(w2, 0.0, 1.0);
      double mass = 0.0;  // mode with M(L) = 0: (m0, v0) = (M_b(L), -M_a(L))
      const Timoshenko::State tip = beam.shoot(w2, b[2], -a[2], &mass);
      omega_[n] = w;
      coeff_[n] = tip[0] * tip[0] / (mass * w2) / delta_per_load;
    }
  }
  double operator()(double t) const {
    double w = static_part_;
    for (size_t n = 0; n < omega_.size(); ++n) w -= coeff_[n] * std::cos(omega_[n] * t);
    return w;
  }
  double omega(int n) const { return omega_[n]; }
  double coeff(int n) const { return coeff_[n]; }
  double omega1() const { return omega_[0]; }

 private:
  std::vector<double> omega_, coeff_;
  double static_part_ = 1.0;
};

// The example rod of docs/validation_references.md (L = 1, r = 1 cm, rho = 1000, E = E_s = 1e7,
// G = E/3, kappa = G A) as a cantilever along x, clamped at node 0, loaded at the tip along -z
// from t = 0.
inline Rod make_cantilever(const StepCase& c) {
  Material m;
  m.youngs_modulus = m.stretch_modulus = 1e7;
  m.shear_modulus = 1e7 / 3.0;
  m.density = 1000.0;
  const double r = 0.01;
  m.kappa = m.shear_modulus * kPi * r * r;
  RodSpec spec;
  spec.elements = c.elements;
  spec.shape.length = 1.0;
  spec.section = make_section(m, r);
  Rod rod = build_rod(spec);
  rod.add_node_drive(NodeDrive{});
  if (c.ghost_clamp) {
    rod.ghost_start().active = true;
    rod.ghost_start().frame = rod.orientations()[0];
  } else {
    SegmentDrive fix;
    fix.origin = rod.orientations()[0];
    rod.add_segment_drive(fix);
  }
  // rotational_inertia_scale: auto for the scaled method (after the clamp, which it reads).
  if (c.method == charts::Method::kSplitRotationScaled)
    rod.set_rotational_inertia_scale(lifting_inertia_scale(rod));
  Load load;
  load.index = c.elements;
  load.value = Vec3(0.0, 0.0, -c.alpha * rod.section().bend);  // L = 1
  rod.add_load(load);
  return rod;
}

// Simulates the case and compares the tip history with the modal series at about 400 samples
// per period of mode 1 (more than 20 per period of mode 4). Only the stepping is timed.
inline StepResult run_step_case(const StepCase& c) {
  Rod rod = make_cantilever(c);
  const Section& sec = rod.section();
  const ModalSeries series(sec.bend, sec.mass_per_length, 1.0);
  const ModalSeries timoshenko(
      Timoshenko{sec.bend, sec.kappa, sec.mass_per_length, sec.inertia_bend, 1.0}, 6);
  StepResult res;
  res.delta = c.alpha / 3.0;  // P L^3/(3B) with P = alpha B / L^2, L = 1
  res.h = c.h > 0.0 ? c.h : c.step_fraction * critical_time_step(rod);
  const double duration = c.periods * 2.0 * kPi / series.omega1();
  res.steps = std::lround(std::ceil(duration / res.h));
  res.simulated_seconds = res.steps * res.h;
  const long every = std::max(1L, std::lround(duration / (400.0 * c.periods) / res.h));
  std::vector<double> tip;
  tip.reserve(res.steps / every + 2);
  const Vec3 g = Vec3::Zero();
  charts::Stepper stepper(c.method);
  const std::clock_t start = std::clock();  // process CPU time: less sensitive to other load
  for (long i = 0; i < res.steps; ++i) {
    stepper.step(rod, i * res.h, res.h, g);
    if ((i + 1) % every == 0) tip.push_back(-rod.positions().back().z());
  }
  res.cpu_seconds = static_cast<double>(std::clock() - start) / CLOCKS_PER_SEC;
  res.finite = rod.finite();
  res.newton_failures = stepper.newton_failures();
  res.newton_iterations = stepper.newton_iterations();
  double sum = 0.0, sum_t = 0.0;
  for (size_t k = 0; k < tip.size(); ++k) {
    const double t = (k + 1) * every * res.h;
    const double e = tip[k] / res.delta - series(t), et = tip[k] / res.delta - timoshenko(t);
    sum += e * e;
    sum_t += et * et;
    res.error_max = std::max(res.error_max, std::abs(e));
  }
  const double count = std::max<double>(1.0, tip.size());
  res.error_rms = std::sqrt(sum / count);
  res.error_rms_timoshenko = std::sqrt(sum_t / count);
  if (!res.finite) res.error_rms = res.error_max = res.error_rms_timoshenko = INFINITY;
  return res;
}

}  // namespace v8
}  // namespace corde
