// V6 (validation_static.md): energy behaviour of the undamped step with the paper's rotational
// update (Integrator::kSemiImplicitEuler, selected explicitly in every step here). The default
// split rotation removes the gyroscopic gain described below: rotation_energy_test.cpp.
//
// Two observations this file pins down:
//  1. An undamped free rod given a random perturbation "gains" about 20% energy at h = 0.5 h_crit.
//     Most of that is not drift. Symplectic Euler keeps a modified energy, which for a mode of
//     frequency omega is I = v^2 + omega^2 x^2 - h omega^2 x v (per unit mass). A random state has
//     x v ~ 0, so it starts with E = I/2. Along the orbit E averages I/2 / (1 - a^2/4), a = omega
//     h, which is higher by a^2 / (4 - a^2). That is 1/3 at a = 1 (the stretch mode at the top of
//     the spectrum when h = 0.5 h_crit). The energy jumps by this O(h^2) offset within a few
//     periods of the fast modes and then stays flat: the translational update alone, and the whole
//     rod with isotropic segment inertia, show no drift. What remains is a slow secular drift of
//     order h. It comes from the explicit gyroscopic term w x I w of the rotational update
//     (docs/model.md: w += h I^-1 (tau - w x I w)), which is not symplectic. With a rod segment's
//     axisymmetric inertia (I3 = 2 I1) that drift is a loss in the free-rod case below.
//  2. A free rigid segment spinning about its axis shows the same term directly. Explicit Euler on
//     Euler's equations multiplies the transverse angular velocity by sqrt(1 + (h Omega)^2) per
//     step, Omega = (I3 - I1)/I1 w3, so the energy grows exponentially at a rate h Omega^2 (O(h)).
//     In the undamped coiling scene the segments reach 1e2 to 1e4 rad/s and this gain runs away.
//     The rod blows up after 10 to 20 s at every h tried (later for a smaller h), not because
//     omega h > 2. A little internal friction (the preset's 10 us on bending and twist) or
//     isotropic inertia (no gyroscopic term) removes it.
// The behaviour follows docs/model.md ("Time integration") and the reference implementation of
// step_regression_test.cpp, which uses the same explicit term. This file states what the paper's
// step does; it does not change it.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <string>

#include "corde_sim/rod/rod_shape.h"
#include "corde_sim/scene/scene.h"
#include "corde_sim/stability/explicit_step_limit.h"
#include "dynamics_util.h"

namespace corde {
namespace {

using dyn::total_energy;
using dyn::undamped_rope_section;

constexpr Integrator kPaper = Integrator::kSemiImplicitEuler;

// Free straight rope, 1 m, N = 20, with a seeded random perturbation of positions (1 mm),
// orientations (up to 0.05 rad), velocities (5 cm/s) and angular velocities (1 rad/s).
// isotropic: segment inertia about d3 set to the one about d1 and d2 (no gyroscopic term).
Rod perturbed_free_rope(bool isotropic) {
  std::mt19937 rng(7);
  auto uni = [&](double a, double b) { return std::uniform_real_distribution<double>(a, b)(rng); };
  auto rv = [&](double s) { return Vec3(uni(-s, s), uni(-s, s), uni(-s, s)); };
  RodSpec spec;
  spec.elements = 20;
  spec.shape.length = 1.0;
  spec.section = undamped_rope_section();
  if (isotropic) spec.section.inertia_twist = spec.section.inertia_bend;
  Rod rod = build_rod(spec);
  for (auto& x : rod.positions()) x += rv(1e-3);
  for (auto& q : rod.orientations())
    q = (q * Quat(Eigen::AngleAxisd(uni(0.0, 0.05), rv(1.0).normalized()))).normalized();
  for (auto& v : rod.velocities()) v = rv(0.05);
  for (auto& w : rod.angular_velocities()) w = rv(1.0);
  return rod;
}

struct DriftRun {
  double offset;  // mean of E/E0 - 1 over the first sixteenth of the run
  double drift;   // mean over the last sixteenth minus that over the first
};

DriftRun run_drift(Rod rod, double h, double duration) {
  const double e0 = total_energy(rod);
  const long n = std::lround(duration / h);
  const long window = n / 16;
  double first = 0.0, last = 0.0;
  for (long k = 0; k < n; ++k) {
    rod.step(k * h, h, Vec3::Zero(), kPaper);
    const double rel = total_energy(rod) / e0 - 1.0;
    if (k < window) first += rel;
    if (k >= n - window) last += rel;
  }
  first /= window;
  last /= window;
  return {first, last - first};
}

// A single undamped stretch spring (N = 1, two free nodes) released from rest at 1% strain: x v = 0
// at the start, so E0 = I/2 exactly, and the mean of E over many periods is E0 / (1 - a^2/4) with
// a = omega h, omega^2 = K_s/l (1/m0 + 1/m1). At a = 1 (where the top stretch mode of a rod sits at
// h = 0.5 h_crit) the mean is 4/3 of E0: the energy symplectic Euler seems to gain from a state at
// rest is this bounded offset. Measured 1.333333 and 1.066667 at a = 1 and 0.5 (to 1e-6). (The
// single segment's h_crit is set by its tilt mode, 1.59 omega, which stays stable at a = 1.)
TEST(EnergyDrift, SymplecticEulerMeanEnergyOffsetOfOneMode) {
  RodSpec spec;
  spec.elements = 1;
  spec.shape.length = 0.1;
  spec.section = undamped_rope_section();
  Rod rod = build_rod(spec);
  const double l = rod.rest_lengths()[0];
  const double m0 = rod.node_masses()[0], m1 = rod.node_masses()[1];
  const double omega = std::sqrt(rod.section().stretch / l * (1.0 / m0 + 1.0 / m1));
  EXPECT_LT(omega * critical_time_step(rod), 2.0);
  rod.positions()[1] *= 1.01;
  for (double a : {1.0, 0.5}) {
    Rod r = rod;
    const double h = a / omega;
    const double e0 = total_energy(r);
    const long n = 200000;  // ~3e4 to 1.6e4 periods: the mean over a non-closing orbit
    double mean = 0.0;
    for (long k = 0; k < n; ++k) {
      r.step(k * h, h, Vec3::Zero(), kPaper);
      mean += total_energy(r);
    }
    mean /= n * e0;
    const double expected = 1.0 / (1.0 - 0.25 * a * a);
    std::printf("one stretch mode, omega h = %.3f: mean E/E0 = %.6f, 1/(1 - a^2/4) = %.6f\n", a,
                mean, expected);
    EXPECT_TRUE(r.finite());
    EXPECT_NEAR(mean, expected, 1e-3);
  }
}

// The earlier session's observation, reproduced. The free undamped rope with a random perturbation
// runs for 1.6 s. Figures from the run below:
// - offset (E/E0 - 1 over the first 0.1 s): 0.213, 0.045, 0.0106 at h = 0.5, 0.25, 0.125 h_crit,
//   an O(h^2) offset (ratios 4.7 and 4.2);
// - drift (last 0.1 s minus first): -0.030, -0.017, -0.0087, an O(h) loss (ratios 1.8 and 1.9).
// With isotropic segment inertia the offset is the same, 0.214, 0.045, 0.0108, and the drift is
// 0.9e-4, 2.8e-4, 0.3e-4 (below 1% of the offset): the drift comes from the gyroscopic term.
TEST(EnergyDrift, FreeRopeOffsetIsOrderH2AndDriftComesFromGyroscopicTerm) {
  const double T = 1.6;
  DriftRun aniso[3], iso[3];
  const double fractions[3] = {0.5, 0.25, 0.125};
  for (int i = 0; i < 3; ++i) {
    for (int k = 0; k < 2; ++k) {
      Rod rod = perturbed_free_rope(k == 1);
      const double h = fractions[i] * critical_time_step(rod);
      (k == 0 ? aniso : iso)[i] = run_drift(rod, h, T);
    }
    std::printf(
        "free rope, h = %.3f h_crit, %.1f s: offset %.4f drift %+.5f (I3 = 2 I1); "
        "offset %.4f drift %+.6f (I3 = I1)\n",
        fractions[i], T, aniso[i].offset, aniso[i].drift, iso[i].offset, iso[i].drift);
  }
  // Offset: about 21% at 0.5 h_crit (the earlier session's figure), order 2 below.
  EXPECT_GT(aniso[0].offset, 0.15);
  EXPECT_LT(aniso[0].offset, 0.30);
  EXPECT_NEAR(aniso[1].offset / aniso[2].offset, 4.0, 0.6);
  EXPECT_NEAR(iso[1].offset / iso[2].offset, 4.0, 0.6);
  for (int i = 0; i < 3; ++i) {
    // Axisymmetric inertia: a secular loss of order h, > 20 times the isotropic rod's.
    EXPECT_LT(aniso[i].drift, 0.0);
    EXPECT_GT(std::abs(aniso[i].drift), 20.0 * std::abs(iso[i].drift));
    // Isotropic inertia: no drift (below 2% of the offset).
    EXPECT_LT(std::abs(iso[i].drift), 0.02 * iso[i].offset);
  }
  EXPECT_NEAR(aniso[1].drift / aniso[2].drift, 2.0, 0.5);
  EXPECT_NEAR(aniso[0].drift / aniso[1].drift, 2.0, 0.5);
}

// The translational update alone (every segment held by a fixed drive) keeps the energy flat after
// the O(h^2) offset: its drift is below 1% of the offset at h = 0.5 and 0.25 h_crit.
TEST(EnergyDrift, TranslationalUpdateAloneHasNoDrift) {
  double offsets[2];
  for (int i = 0; i < 2; ++i) {
    Rod rod = perturbed_free_rope(false);
    for (int s = 0; s < rod.num_segments(); ++s) {
      SegmentDrive d;
      d.segment = s;
      d.origin = rod.orientations()[s];
      rod.add_segment_drive(d);
    }
    for (auto& w : rod.angular_velocities()) w.setZero();
    const double f = i == 0 ? 0.5 : 0.25;
    const DriftRun r = run_drift(rod, f * critical_time_step(rod), 1.6);
    std::printf("frozen segments, h = %.2f h_crit: offset %.5f drift %+.2e\n", f, r.offset,
                r.drift);
    EXPECT_LT(std::abs(r.drift), 0.01 * r.offset);
    offsets[i] = r.offset;
  }
  EXPECT_NEAR(offsets[0] / offsets[1], 4.0, 1.0);
}

// A free rigid segment (N = 1, no stretch or coupling stiffness, so no forces) with the rope's
// inertia (I3 = 2 I1), body angular velocity (w1, 0, w3). The exact motion keeps the energy. The
// step's explicit gyroscopic term rotates (w1, w2) at Omega = (I3 - I1)/I1 w3 = w3 by explicit
// Euler, which multiplies |w_perp|^2 by exactly 1 + (h Omega)^2 per step (w3 stays constant).
// Over T = 0.1 s with w3 = 100 rad/s that is +10.5% of the transverse energy at h = 1e-4 s and
// +5.1% at h/2 (order h). With isotropic inertia there is no gain.
TEST(EnergyDrift, RigidSpinningSegmentGainsEnergyFromExplicitGyroscopicTerm) {
  for (bool isotropic : {false, true}) {
    double gain[2];
    for (int k = 0; k < 2; ++k) {
      Section sec = undamped_rope_section();
      sec.stretch = 0.0;
      sec.kappa = 0.0;
      if (isotropic) sec.inertia_twist = sec.inertia_bend;
      Rod rod("rigid", {Vec3::Zero(), Vec3(0.1, 0.0, 0.0)},
              {Quat(Eigen::AngleAxisd(0.5 * std::acos(-1.0), Vec3::UnitY()))}, sec);
      const double w1 = 5.0, w3 = 100.0;
      rod.angular_velocities()[0] = Vec3(w1, 0.0, w3);
      const Vec3 in = rod.segment_inertia(0);
      const double omega = (in.z() - in.x()) / in.x() * w3;
      const double h = k == 0 ? 1e-4 : 5e-5;
      const long n = std::lround(0.1 / h);
      const double e_perp0 = 0.5 * in.x() * w1 * w1;
      const double e0 = rod.energies(Vec3::Zero()).kinetic_rotation;
      for (long i = 0; i < n; ++i) rod.step(i * h, h, Vec3::Zero(), kPaper);
      const double e1 = rod.energies(Vec3::Zero()).kinetic_rotation;
      const double predicted = e_perp0 * (std::pow(1.0 + h * h * omega * omega, n) - 1.0);
      gain[k] = (e1 - e0) / e_perp0;
      std::printf(
          "rigid segment, I3/I1 = %.1f, h = %.0e s: transverse energy gain %.6f "
          "(explicit Euler prediction %.6f)\n",
          in.z() / in.x(), h, gain[k], predicted / e_perp0);
      EXPECT_NEAR(e1 - e0, predicted, 1e-9 * e0);
      EXPECT_NEAR(rod.angular_velocities()[0].z(), w3, 1e-9 * w3);
    }
    if (isotropic) {
      EXPECT_LT(std::abs(gain[0]), 1e-12);
    } else {
      EXPECT_NEAR(gain[0], 0.105, 0.002);
      EXPECT_NEAR(gain[0] / gain[1], 2.0, 0.1);
    }
  }
}

// coiling_50 (paper_rope, N = 50, start clamp spun at pi rad/s), run for 20 s, four times the
// scene's duration. Undamped (gamma_t = gamma_r = 0) at h = 0.5 h_crit, the rod gets past 5 s but
// blows up later: E passes 1e3 J at 11.4 s (185 J 0.2 s before), segments at > 1e4 rad/s.
// Measured blow-up times were 9.5, 11.4, 15.1, 20.8 s at h = 0.8, 0.5, 0.25, 0.125 h_crit; at
// 0.0625 h_crit the rod survived 30 s but had reached 170 J. So the blow-up comes later as h
// shrinks, the signature of the O(h) gyroscopic gain and not of a step above the stability limit.
// Either the preset's 10 us retardation on bending and twist (gamma_r only) or isotropic inertia
// keeps it bounded: max E 1.21 J and 3.65 J over 20 s.
TEST(EnergyDrift, UndampedCoilingBlowsUpFromGyroscopicGain) {
  const std::string path = std::string(CORDE_SIM_SOURCE_DIR) + "/config/scenes/coiling_50.yaml";
  const Rod base = load_scene(path).world.rods()[0];
  struct Case {
    const char* name;
    double gamma_r;
    bool isotropic;
  };
  const Section s0 = base.section();
  const double tau_r = 1e-5;               // paper_rope's retardation on bending and twist
  const double gamma_r = tau_r * s0.bend;  // gamma_r = tau E I
  const Case cases[3] = {{"undamped", 0.0, false},
                         {"gamma_r = 10 us E I", gamma_r, false},
                         {"undamped, I3 = I1", 0.0, true}};
  double t_blow[3], e_max[3];
  for (int c = 0; c < 3; ++c) {
    Rod rod = base;
    Section sec = s0;
    sec.gamma_t = 0.0;
    sec.gamma_r = cases[c].gamma_r;
    if (cases[c].isotropic) sec.inertia_twist = sec.inertia_bend;
    rod.set_section(sec);
    const double h = 0.5 * critical_time_step(rod);
    const long n = std::lround(20.0 / h);
    t_blow[c] = -1.0;
    e_max[c] = 0.0;
    for (long k = 0; k < n; ++k) {
      rod.step(k * h, h, Vec3::Zero(), kPaper);
      if (k % 200 != 0) continue;
      const double e = total_energy(rod);
      if (!rod.finite() || !(e < 1e3)) {
        t_blow[c] = (k + 1) * h;
        break;
      }
      e_max[c] = std::max(e_max[c], e);
    }
    std::printf("coiling_50, %s, h = 0.5 h_crit = %.3e s: %s %.2f s, max E %.3f J\n", cases[c].name,
                h, t_blow[c] > 0.0 ? "blew up at" : "bounded through",
                t_blow[c] > 0.0 ? t_blow[c] : 20.0, e_max[c]);
  }
  EXPECT_GT(t_blow[0], 5.0);   // the scene's own duration is fine even undamped
  EXPECT_LT(t_blow[0], 20.0);  // but it runs away later
  EXPECT_LT(t_blow[1], 0.0);
  EXPECT_LT(e_max[1], 3.0);
  EXPECT_LT(t_blow[2], 0.0);
  EXPECT_LT(e_max[2], 20.0);
}

}  // namespace
}  // namespace corde
