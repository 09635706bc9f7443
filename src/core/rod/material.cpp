#include "corde_sim/rod/material.h"

#include <cmath>
#include <stdexcept>

namespace corde {
namespace {

void check_value(const char* name, double v, bool allow_zero) {
  if (!std::isfinite(v)) throw std::invalid_argument(std::string(name) + " is not finite");
  if (v < 0.0 || (!allow_zero && v == 0.0))
    throw std::invalid_argument(std::string(name) +
                                (allow_zero ? " must be >= 0" : " must be > 0"));
}

// Picks a direct stiffness if given, else modulus times section moment; one of them must be > 0.
double pick(const char* direct_name, double direct, const char* modulus_name, double modulus,
            double moment) {
  check_value(direct_name, direct, true);
  check_value(modulus_name, modulus, true);
  if (direct > 0.0) return direct;
  if (modulus > 0.0) return modulus * moment;
  throw std::invalid_argument(std::string("need ") + modulus_name + " > 0 or " + direct_name +
                              " > 0");
}

constexpr double kPi = 3.14159265358979323846;

// kappa is the Timoshenko shear stiffness G A of a circular section (docs/model.md); the paper's
// printed kappa values were tuned under its r^2 inertia and would be far too stiff here.
Material from_moduli(double E, double G, double Es, double rho, double radius, double tau_t,
                     double tau_r) {
  Material m;
  m.youngs_modulus = E;
  m.shear_modulus = G;
  m.stretch_modulus = Es;
  m.density = rho;
  const double area = kPi * radius * radius;
  m.kappa = G * area;
  // Kelvin-Voigt internal friction: a mode of frequency w gets damping ratio w * tau / 2. Explicit
  // integration stays stable while h tau w^2 < 2, so the presets' retardation times are about
  // 0.1 / w_max at a typical element length: they calm the highest (numerical) modes without
  // lowering the stable step much, and leave the slow shape modes almost undamped.
  m.gamma_t = tau_t * Es * area;
  m.gamma_r = tau_r * E * area * radius * radius / 4.0;
  return m;
}

}  // namespace

Section make_section(const Material& m, double radius) {
  check_value("radius", radius, false);
  check_value("density", m.density, false);
  check_value("kappa", m.kappa, true);
  check_value("gamma_t", m.gamma_t, true);
  check_value("gamma_r", m.gamma_r, true);
  check_value("max_strain", m.max_strain, true);
  const double r2 = radius * radius;
  const double area = kPi * r2;
  Section s;
  s.radius = radius;
  s.bend =
      pick("bend_stiffness", m.bend_stiffness, "youngs_modulus", m.youngs_modulus, area * r2 / 4.0);
  s.twist =
      pick("twist_stiffness", m.twist_stiffness, "shear_modulus", m.shear_modulus, area * r2 / 2.0);
  s.stretch =
      pick("stretch_stiffness", m.stretch_stiffness, "stretch_modulus", m.stretch_modulus, area);
  s.kappa = m.kappa;
  s.gamma_t = m.gamma_t;
  s.gamma_r = m.gamma_r;
  s.mass_per_length = m.density * area;
  s.inertia_bend = m.density * area * r2 / 4.0;
  s.inertia_twist = m.density * area * r2 / 2.0;
  s.max_strain = m.max_strain;
  return s;
}

const std::vector<MaterialPreset>& material_presets() {
  static const std::vector<MaterialPreset> presets = [] {
    std::vector<MaterialPreset> p;
    // The paper's Table 2 moduli, density and radius, with the physical section formulas.
    p.push_back({"paper_rope",
                 "CoRdE Table 2 rope: E = G = 0.5 MPa, E_s = 20 MPa, rho = 1300, r = 1 cm; "
                 "kappa = G A; retardation 40 us stretch, 10 us bend/twist (elements of 10 cm)",
                 from_moduli(0.5e6, 0.5e6, 20e6, 1300, 0.01, 4e-5, 1e-5), 0.01});
    p.push_back({"paper_wire",
                 "CoRdE Table 2 wire: E = 200 MPa, G = 100 MPa, E_s = 100 MPa, rho = 7860, "
                 "r = 1 mm (printed MPa: 1000x softer than steel); kappa = G A; retardation 1 us "
                 "(elements of 2 mm)",
                 from_moduli(200e6, 100e6, 100e6, 7860, 0.001, 1e-6, 1e-6), 0.001});
    p.push_back({"paper_thread",
                 "CoRdE Table 2 thread: E = G = 10 Pa, E_s = 20 kPa, rho = 1300, r = 1 mm; "
                 "kappa = G A; retardation 0.1 ms stretch, 1 ms bend/twist (elements of 1 cm)",
                 from_moduli(10, 10, 0.02e6, 1300, 0.001, 1e-4, 1e-3), 0.001});
    // Real materials, handbook values (solid sections unless noted).
    p.push_back({"steel_wire",
                 "Spring steel wire: E = 200 GPa, G = 79 GPa (nu = 0.27), rho = 7850 "
                 "(handbook values); r = 0.5 mm; retardation 0.1 us (elements of 1 cm)",
                 from_moduli(200e9, 79e9, 200e9, 7850, 0.0005, 1e-7, 1e-7), 0.0005});
    p.push_back({"nylon_rope",
                 "Braided nylon rope, r = 5 mm: effective axial modulus 1 GPa (fibre 2-4 GPa, "
                 "braid elongation ~10% at working load), bending modulus 20 MPa and shear 7 MPa "
                 "(loose braid bends far more easily than its fibres), rho = 800 (nylon 1140 "
                 "at ~70% packing); retardation 1 us stretch, 10 us bend/twist (elements of 2 cm)",
                 from_moduli(20e6, 7e6, 1e9, 800, 0.005, 1e-6, 1e-5), 0.005});
    p.push_back({"soft_cable",
                 "PVC-insulated electrical cable, r = 3 mm: bending modulus 30 MPa (B ~ 2e-3 "
                 "N m^2, a limp power cord), shear 10 MPa, axial 5 GPa carried by the copper "
                 "strands (~5% of the section at 120 GPa), rho = 2000; retardation 0.5 us stretch, "
                 "10 us bend/twist (elements of 2 cm)",
                 from_moduli(30e6, 10e6, 5e9, 2000, 0.003, 5e-7, 1e-5), 0.003});
    // Axial strain limits: where each material stops behaving elastically (yield of steel and
    // copper, the working elongation of a nylon braid) or, for the paper's soft materials, a
    // strain their tests never approach.
    const double max_strain[] = {0.1, 0.01, 1.0, 0.005, 0.15, 0.02};
    for (size_t i = 0; i < p.size(); ++i) p[i].material.max_strain = max_strain[i];
    return p;
  }();
  return presets;
}

const MaterialPreset& material_preset(const std::string& name) {
  std::string known;
  for (const auto& p : material_presets()) {
    if (p.name == name) return p;
    known += (known.empty() ? "" : ", ") + p.name;
  }
  throw std::invalid_argument("unknown material preset '" + name + "' (known: " + known + ")");
}

}  // namespace corde
