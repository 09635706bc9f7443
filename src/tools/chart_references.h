// Reference solutions and test rods of the charts (corde_charts): the cantilever sagging under
// its own weight (the peers' test of docs/peers.md) as a planar extensible, shearable elastica
// solved by shooting, the clamped-free Euler-Bernoulli mode shapes, and the rods the charts run.
#pragma once

#include <cmath>
#include <stdexcept>

#include "corde_sim/rod/material.h"
#include "corde_sim/rod/rod.h"
#include "corde_sim/rod/rod_shape.h"

namespace corde {
namespace charts {

// Planar cantilever along x clamped at s = 0 under a dead weight q per length along -z: bending B,
// stretch EA, shear kappa (kappa or EA = 0: that strain is not allowed, the classical elastica).
// The internal force is known in closed form, n(s) = -q (L - s) e_z, so the equations are
//   theta' = M/B,  M' = -q (L - s) x',  x' = (1 + eps) cos(theta) + gam sin(theta),
//   z' = -(1 + eps) sin(theta) + gam cos(theta),
//   eps = q (L - s) sin(theta)/EA,  gam = -q (L - s) cos(theta)/kappa
// (theta the droop angle of the tangent, M the bending moment). Integrated by RK4 from the free
// end (M = 0) for a trial tip angle; the angle is bisected until theta(0) = 0.
struct SagElastica {
  double bend, stretch, kappa, q, length;
  int steps = 4000;

  struct Tip {
    double x, z, angle;
  };

  // Integrates from s = L (theta = tip_angle, M = 0) to s = 0; returns theta(0) and the tip
  // relative to the clamp.
  double shoot(double tip_angle, Tip* tip) const {
    const double ds = length / steps;
    double th = tip_angle, m = 0.0, dx = 0.0, dz = 0.0;
    auto rhs = [&](double s, double theta, double moment, double* d) {
      const double load = q * (length - s);
      const double eps = stretch > 0.0 ? load * std::sin(theta) / stretch : 0.0;
      const double gam = kappa > 0.0 ? -load * std::cos(theta) / kappa : 0.0;
      const double xp = (1.0 + eps) * std::cos(theta) + gam * std::sin(theta);
      d[0] = moment / bend;
      d[1] = -load * xp;
      d[2] = xp;
      d[3] = -(1.0 + eps) * std::sin(theta) + gam * std::cos(theta);
    };
    for (int i = steps; i > 0; --i) {  // s from L down to 0: step -ds
      const double s = i * ds;
      double k1[4], k2[4], k3[4], k4[4];
      rhs(s, th, m, k1);
      rhs(s - 0.5 * ds, th - 0.5 * ds * k1[0], m - 0.5 * ds * k1[1], k2);
      rhs(s - 0.5 * ds, th - 0.5 * ds * k2[0], m - 0.5 * ds * k2[1], k3);
      rhs(s - ds, th - ds * k3[0], m - ds * k3[1], k4);
      th -= ds / 6.0 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0]);
      m -= ds / 6.0 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1]);
      dx += ds / 6.0 * (k1[2] + 2 * k2[2] + 2 * k3[2] + k4[2]);
      dz += ds / 6.0 * (k1[3] + 2 * k2[3] + 2 * k3[3] + k4[3]);
    }
    if (tip) *tip = Tip{dx, dz, tip_angle};
    return th;
  }

  // The tip (x, z) relative to the clamp and its droop angle.
  Tip solve() const {
    double lo = 0.0, hi = 0.5 * 3.14159265358979323846;
    if (shoot(hi, nullptr) < 0.0) throw std::runtime_error("SagElastica: no bracket");
    for (int it = 0; it < 60; ++it) {
      const double mid = 0.5 * (lo + hi);
      (shoot(mid, nullptr) > 0.0 ? hi : lo) = mid;
    }
    Tip tip{};
    shoot(0.5 * (lo + hi), &tip);
    return tip;
  }
};

// Clamped-free Euler-Bernoulli mode shape (beta = beta_n L the root, x in [0, 1] of the length),
// 2 at the free end.
inline double clamped_free_mode(double beta, double x) {
  const double sigma = (std::cosh(beta) + std::cos(beta)) / (std::sinh(beta) + std::sin(beta));
  const double b = beta * x;
  return std::cosh(b) - std::cos(b) - sigma * (std::sinh(b) - std::sin(b));
}

// A material with E_s = E, G = E/3, kappa = G A (the library presets' convention).
inline Material rod_material(double youngs, double density, double radius) {
  Material m;
  m.youngs_modulus = m.stretch_modulus = youngs;
  m.shear_modulus = youngs / 3.0;
  m.density = density;
  m.kappa = m.shear_modulus * 3.14159265358979323846 * radius * radius;
  return m;
}

// A straight rod along x from the origin, d1 = z (bends in x-z under z loads), node 0 fixed;
// `ghost`: a ghost frame clamps it (segment 0 free), else it is pinned.
inline Rod fixed_start_rod(const Material& m, double radius, double length, int elements,
                           bool ghost) {
  RodSpec spec;
  spec.elements = elements;
  spec.shape.length = length;
  spec.shape.direction = Vec3::UnitX();
  spec.shape.reference_d1 = Vec3::UnitZ();
  spec.section = make_section(m, radius);
  Rod rod = build_rod(spec);
  rod.add_node_drive(NodeDrive{});
  if (ghost) {
    rod.ghost_start().active = true;
    rod.ghost_start().frame = rod.orientations()[0];
  }
  return rod;
}

// Turns every segment's frame so that d3 follows its chord (no twist added).
inline void align_frames_to_chords(Rod* rod) {
  for (int s = 0; s < rod->num_segments(); ++s) {
    Quat& q = rod->orientations()[s];
    const Vec3 t = (rod->positions()[s + 1] - rod->positions()[s]).normalized();
    q = (Quat::FromTwoVectors(q * Vec3::UnitZ(), t) * q).normalized();
  }
}

}  // namespace charts
}  // namespace corde
