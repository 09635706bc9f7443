// Materials in SI units and the section constants derived from them.
#pragma once

#include <string>
#include <vector>

namespace corde {

// A rod material. Stiffness is given either as moduli (Pa), turned into section stiffness with
// the rod's radius, or directly as section stiffness; a direct value > 0 overrides the modulus.
struct Material {
  double youngs_modulus = 0.0;     // E (Pa), bending
  double shear_modulus = 0.0;      // G (Pa), twist
  double stretch_modulus = 0.0;    // E_s (Pa), stretch; braided ropes have E_s >> E
  double bend_stiffness = 0.0;     // B (N m^2), overrides E pi r^4 / 4
  double twist_stiffness = 0.0;    // C (N m^2), overrides G pi r^4 / 2
  double stretch_stiffness = 0.0;  // K_s (N), overrides E_s pi r^2
  double density = 0.0;            // rho (kg/m^3)
  double kappa = 0.0;              // coupling penalty (N), acts like shear stiffness G A_eff
  double gamma_t = 0.0;            // translational internal friction (N s)
  double gamma_r = 0.0;            // rotational internal friction (N m^2 s)
  // Axial strain beyond which the material is overstretched (yields, slips or tears): the node
  // warns and can let a holder slip. 0 = no limit. Not used by the dynamics.
  double max_strain = 0.0;
};

// Per-length constants of a rod section (the model's K_s, K_11 = K_22 = B, K_33 = C, ...).
struct Section {
  double radius = 0.0;
  double bend = 0.0;             // B (N m^2)
  double twist = 0.0;            // C (N m^2)
  double stretch = 0.0;          // K_s (N)
  double kappa = 0.0;            // N
  double gamma_t = 0.0;          // N s
  double gamma_r = 0.0;          // N m^2 s
  double mass_per_length = 0.0;  // rho pi r^2 (kg/m)
  double inertia_bend = 0.0;     // rho pi r^4 / 4 (kg m), about d1 and d2, per length
  double inertia_twist = 0.0;    // rho pi r^4 / 2 (kg m), about d3, per length
  double max_strain = 0.0;       // Material::max_strain (0 = no limit)
};

// Throws std::invalid_argument naming the offending field if the material cannot be used
// (non-finite, negative, or missing stiffness).
Section make_section(const Material& m, double radius);

struct MaterialPreset {
  std::string name;
  std::string description;  // where the numbers come from
  Material material;
  double radius;  // typical radius (m) the preset was derived for
};

// All named presets; see material.cpp for their derivation.
const std::vector<MaterialPreset>& material_presets();
// Throws std::invalid_argument listing the known names if `name` is unknown.
const MaterialPreset& material_preset(const std::string& name);

}  // namespace corde
