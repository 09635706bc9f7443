// Editing an existing rod: a new discretisation of its current state, and the material that
// reproduces its section (so that one constant can be changed and the section rebuilt).
#pragma once

#include "corde_sim/rod/material.h"
#include "corde_sim/rod/rod.h"

namespace corde {

// The moduli that make_section() turns back into `section` at section.radius:
// E = 4B/(pi r^4), G = 2C/(pi r^4), E_s = K_s/(pi r^2), rho = mu/(pi r^2); kappa, gamma_t and
// gamma_r are copied. Throws std::invalid_argument if the radius is not > 0.
Material equivalent_material(const Section& section);

// Kelvin-Voigt internal friction with retardation time tau (s): every mode of frequency w gets the
// damping ratio w tau / 2, i.e. gamma_t = tau E_s pi r^2 and gamma_r = tau E pi r^4 / 4.
void set_retardation_time(Material* m, double radius, double tau);

// The rod resampled at `elements` segments, with the same section, name and boundary conditions.
// New nodes sit at equal steps of the material (rest arc-length) coordinate s on the current
// centreline; positions and velocities are interpolated by a cubic in s through the old nodes,
// world angular velocities, stretch and rest strains linearly, orientations by slerp between
// segment midpoints and then turned so that d3 follows the new chord. Each segment's rest length
// keeps the local stretch, so the total rest length changes by the chord-versus-arc difference,
// O((l kappa)^2) relative, and a rod at rest stays nearly at rest. Drives, loads, ghost frames,
// point masses and added inertias move to the node or segment at the same s (mass scales: the old
// segment's at the new midpoint) (ends stay ends); two drives landing on one index keep
// the last. Throws std::invalid_argument if elements < 1.
Rod resample_rod(const Rod& rod, int elements);

}  // namespace corde
