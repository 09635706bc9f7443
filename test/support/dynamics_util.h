// Helpers shared by the dynamic validation tests (frequencies, pendulum, stability edge, coiling):
// the example rod of docs/validation_references.md, a sampled time loop, and spectral peak finding
// (radix-2 FFT, Hann window, zero padding, parabolic refinement of the peak).
#pragma once

#include <algorithm>
#include <cmath>
#include <complex>
#include <stdexcept>
#include <utility>
#include <vector>

#include "corde_sim/rod/material.h"
#include "corde_sim/rod/rod.h"
#include "corde_sim/rod/rod_shape.h"

namespace corde {
namespace dyn {

constexpr double kPi = 3.14159265358979323846;

// The example rod of docs/validation_references.md: r = 1 cm, rho = 1000, E = E_s = 1e7, G = E/3,
// and the coupling penalty kappa = kappa_scale * G A (kappa_scale 1: the Timoshenko shear stiffness
// of the section with shear coefficient 1, as the library's presets use).
inline Material example_material(double kappa_scale = 1.0) {
  Material m;
  m.youngs_modulus = 1e7;
  m.stretch_modulus = 1e7;
  m.shear_modulus = 1e7 / 3.0;
  m.density = 1000.0;
  m.kappa = kappa_scale * m.shear_modulus * kPi * 0.01 * 0.01;
  return m;
}

// A straight rod from the origin along `direction`, d1 along `d1`.
inline Rod straight_rod(const Material& m, double radius, double length, int elements,
                        const Vec3& direction = Vec3::UnitX(), const Vec3& d1 = Vec3::UnitZ()) {
  RodSpec spec;
  spec.elements = elements;
  spec.shape.length = length;
  spec.shape.direction = direction;
  spec.shape.reference_d1 = d1;
  spec.section = make_section(m, radius);
  return build_rod(spec);
}

// Turns every segment's frame so that d3 follows its current chord (no twist added): a shape
// set through the node positions then starts without coupling-penalty strain.
inline void align_frames_to_chords(Rod* rod) {
  for (int s = 0; s < rod->num_segments(); ++s) {
    Quat& q = rod->orientations()[s];
    const Vec3 t = (rod->positions()[s + 1] - rod->positions()[s]).normalized();
    q = (Quat::FromTwoVectors(q * Vec3::UnitZ(), t) * q).normalized();
  }
}

// Steps the rod from t = 0 with step h for `steps` steps; sample(t) is called at t = 0 and after
// every `every` steps. If sample returns false the run stops early.
template <class Sample>
void run(Rod* rod, double h, long steps, long every, const Vec3& gravity, Sample&& sample) {
  if (!sample(0.0)) return;
  for (long i = 0; i < steps; ++i) {
    rod->step(i * h, h, gravity);
    if ((i + 1) % every == 0 && !sample((i + 1) * h)) return;
  }
}

// In-place iterative radix-2 FFT (forward, no scaling); the size must be a power of two.
inline void fft(std::vector<std::complex<double>>* data) {
  std::vector<std::complex<double>>& a = *data;
  const size_t n = a.size();
  if (n == 0 || (n & (n - 1)) != 0) throw std::invalid_argument("fft: size not a power of two");
  for (size_t i = 1, j = 0; i < n; ++i) {  // bit-reversal permutation
    size_t bit = n >> 1;
    for (; j & bit; bit >>= 1) j ^= bit;
    j ^= bit;
    if (i < j) std::swap(a[i], a[j]);
  }
  for (size_t len = 2; len <= n; len <<= 1) {
    const double ang = -2.0 * kPi / static_cast<double>(len);
    const std::complex<double> wl(std::cos(ang), std::sin(ang));
    for (size_t i = 0; i < n; i += len) {
      std::complex<double> w(1.0, 0.0);
      for (size_t k = 0; k < len / 2; ++k) {
        const std::complex<double> u = a[i + k], v = a[i + k + len / 2] * w;
        a[i + k] = u + v;
        a[i + k + len / 2] = u - v;
        w *= wl;
      }
    }
  }
}

// Frequency (Hz) of the strongest spectral peak of x (sampled every dt seconds) inside
// [f_lo, f_hi]. The linear trend is removed first (a free rod may drift rigidly), then a Hann
// window, zero padding to at least `pad` times the length, and a parabola through the log
// magnitudes of the top bin and its neighbours (exact for a Gaussian lobe, and the Hann lobe is
// close to one: with pad >= 8 the bias is far below 1e-4 of the peak's frequency for 20 periods).
inline double peak_frequency(const std::vector<double>& x, double dt, double f_lo, double f_hi,
                             int pad = 16) {
  const size_t n = x.size();
  if (n < 8) throw std::invalid_argument("peak_frequency: too few samples");
  double st = 0.0, sx = 0.0, stt = 0.0, stx = 0.0;
  for (size_t i = 0; i < n; ++i) {
    const double t = static_cast<double>(i);
    st += t;
    sx += x[i];
    stt += t * t;
    stx += t * x[i];
  }
  const double slope = (n * stx - st * sx) / (n * stt - st * st);
  const double offset = (sx - slope * st) / n;
  size_t m = 1;
  while (m < n * static_cast<size_t>(pad)) m <<= 1;
  std::vector<std::complex<double>> a(m, 0.0);
  for (size_t i = 0; i < n; ++i) {
    const double w = 0.5 - 0.5 * std::cos(2.0 * kPi * i / (n - 1));
    a[i] = w * (x[i] - offset - slope * static_cast<double>(i));
  }
  fft(&a);
  const double df = 1.0 / (dt * m);
  const size_t lo = std::max<size_t>(1, static_cast<size_t>(std::ceil(f_lo / df)));
  const size_t hi = std::min(m / 2 - 1, static_cast<size_t>(std::floor(f_hi / df)));
  if (lo >= hi) throw std::invalid_argument("peak_frequency: empty band");
  size_t k = lo;
  for (size_t i = lo; i <= hi; ++i)
    if (std::abs(a[i]) > std::abs(a[k])) k = i;
  const double l = std::log(std::abs(a[k - 1]) + 1e-300), c = std::log(std::abs(a[k]) + 1e-300),
               r = std::log(std::abs(a[k + 1]) + 1e-300);
  const double den = l - 2.0 * c + r;
  const double delta = den < 0.0 ? 0.5 * (l - r) / den : 0.0;
  return (static_cast<double>(k) + delta) * df;
}

// Elastic plus kinetic energy (no gravity): what an undamped free rod conserves.
inline double total_energy(const Rod& rod) {
  const Energies e = rod.energies(Vec3::Zero());
  return e.elastic() + e.kinetic();
}

// paper_rope material (E = G = 0.5 MPa, E_s = 20 MPa, rho = 1300, r = 1 cm; I3 = 2 I1) without
// friction.
inline Section undamped_rope_section() {
  Material m = material_preset("paper_rope").material;
  m.gamma_t = 0.0;
  m.gamma_r = 0.0;
  return make_section(m, 0.01);
}

// The velocity of the rod's centre of mass.
inline Vec3 mean_velocity(const Rod& rod) {
  Vec3 v = Vec3::Zero();
  double m = 0.0;
  for (int i = 0; i < rod.num_nodes(); ++i) {
    v += rod.node_masses()[i] * rod.velocities()[i];
    m += rod.node_masses()[i];
  }
  return v / m;
}

// Observed order of convergence from errors at N and 2N.
inline double observed_order(double err_n, double err_2n) {
  return std::log(std::abs(err_n) / std::abs(err_2n)) / std::log(2.0);
}

}  // namespace dyn
}  // namespace corde
