// Helpers shared by the static and invariant validation tests: the example rod of
// docs/validation_references.md, cantilever clamps, and convergence arithmetic.
#pragma once

#include <cmath>

#include "corde_sim/rod/material.h"
#include "corde_sim/rod/rod.h"
#include "corde_sim/rod/rod_shape.h"

namespace corde {
namespace val {

constexpr double kPi = 3.14159265358979323846;
constexpr double kLength = 1.0, kRadius = 0.01;

// The example rod of docs/validation_references.md: r = 1 cm, rho = 1000, E = E_s = 1e7 Pa,
// G = E/3, the coupling penalty kappa = G A (a Timoshenko shear stiffness with shear
// coefficient 1). `stiff` multiplies E_s and kappa: the elastica references are inextensible and
// unshearable, and with stiff = 1e3 stretch and shear change their tip positions by < 1e-6 L.
inline Material example_material(double stiff = 1.0, double youngs = 1e7) {
  Material m;
  m.youngs_modulus = youngs;
  m.shear_modulus = youngs / 3.0;
  m.stretch_modulus = stiff * youngs;
  m.density = 1000.0;
  m.kappa = stiff * m.shear_modulus * kPi * kRadius * kRadius;
  return m;
}

// A straight rod from the origin along x, d1 = z, d2 = -y, d3 = x (bends in x-z under z loads).
inline Rod straight_rod(const Material& m, int elements, double length = kLength) {
  RodSpec spec;
  spec.elements = elements;
  spec.shape.length = length;
  spec.shape.direction = Vec3::UnitX();
  spec.shape.reference_d1 = Vec3::UnitZ();
  spec.section = make_section(m, kRadius);
  return build_rod(spec);
}

// Natural clamp: node 0 and segment 0 fixed (bending acts at the end of segment 0, O(1/N) bias).
// Ghost clamp: node 0 fixed, segment 0 free, a fixed ghost frame before it (docs/model.md).
enum class Clamp { kNatural, kGhost };

inline const char* clamp_name(Clamp c) { return c == Clamp::kNatural ? "natural" : "ghost"; }

inline void clamp_start(Rod* rod, Clamp clamp) {
  NodeDrive nd;
  nd.node = 0;
  nd.origin = rod->positions()[0];
  rod->add_node_drive(nd);
  if (clamp == Clamp::kNatural) {
    SegmentDrive sd;
    sd.segment = 0;
    sd.origin = rod->orientations()[0];
    rod->add_segment_drive(sd);
  } else {
    rod->ghost_start().active = true;
    rod->ghost_start().frame = rod->orientations()[0];
  }
}

inline void clamp_end(Rod* rod, Clamp clamp) {
  const int n = rod->num_segments();
  NodeDrive nd;
  nd.node = n;
  nd.origin = rod->positions()[n];
  rod->add_node_drive(nd);
  if (clamp == Clamp::kNatural) {
    SegmentDrive sd;
    sd.segment = n - 1;
    sd.origin = rod->orientations()[n - 1];
    rod->add_segment_drive(sd);
  } else {
    rod->ghost_end().active = true;
    rod->ghost_end().frame = rod->orientations()[n - 1];
  }
}

// Angle (rad) of segment s's tangent d3 below the x axis, in the x-z plane.
inline double droop_angle(const Rod& rod, int s) {
  const Vec3 d3 = rod.orientations()[s] * Vec3::UnitZ();
  return std::atan2(-d3.z(), d3.x());
}

// Observed order of convergence from errors at N and 2N.
inline double observed_order(double err_n, double err_2n) {
  return std::log(std::abs(err_n) / std::abs(err_2n)) / std::log(2.0);
}

// Richardson extrapolation of a first-order sequence from N and 2N.
inline double richardson1(double f_n, double f_2n) { return 2.0 * f_2n - f_n; }

}  // namespace val
}  // namespace corde
