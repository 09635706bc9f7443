// How a static equilibrium moves when material constants change: at an equilibrium
// g(x, p) = 0 (g the energy's gradient over the free unknowns) the implicit function theorem gives
// dx/dp = -H^-1 dg/dp, H the Hessian statics factorises (block tridiagonal, O(N)). Every energy
// term is linear in its constant, so dg/dp is the gradient with the constants' rates in their
// place (model/rod_system.h): exact, one factorisation for all parameters, no re-solve. Defined
// in statics.cpp, whose unknowns it shares. The parameter fit (corde_fit) takes its Jacobian
// from it.
#pragma once

#include <vector>

#include "corde_sim/statics/statics.h"

namespace corde {

// d/dp of the section constants the equilibrium depends on (units of the constant per unit of p).
struct SectionRate {
  double bend = 0.0;     // dB/dp
  double twist = 0.0;    // dC/dp
  double stretch = 0.0;  // dK_s/dp
  double kappa = 0.0;    // d kappa/dp
  // d(mass per length)/dp: the nodes' share of the section's mass (mass scales included, the
  // point masses of add_node_mass not) grows by it over the section's mass per length.
  double mass_per_length = 0.0;
};

// Per parameter: d(node position)/dp (N+1) and the segments' body rotation per unit of p (N;
// dq/dp = (1/2) q (x) (0, rotation)). Held nodes and segments do not move.
struct StaticSensitivity {
  std::vector<Vec3> positions;
  std::vector<Vec3> rotations;
};

// The sensitivities at the rod's current state, which must be a converged solve_statics() at the
// same gravity, t and options (not checked: elsewhere the result has no meaning). Solved with the
// Hessian's block Cholesky, or its LU where it is not positive definite or dead torques act (then
// with the full Jacobian of the residual). Throws std::runtime_error when H is singular (a free
// rigid motion: a neutral equilibrium has no unique sensitivity). Velocities are zeroed.
std::vector<StaticSensitivity> static_sensitivity(Rod& rod, const Vec3& gravity, double t,
                                                  const std::vector<SectionRate>& rates,
                                                  const StaticOptions& options = StaticOptions());

}  // namespace corde
