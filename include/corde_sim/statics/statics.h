// Static equilibrium of a rod: the minimum of its total potential energy (elastic, gravity, dead
// loads) with its kinematic nodes and segments held where their drives put them at time t.
//
// Unknowns are the free node positions and incremental rotation vectors of the free segments
// (q <- q (x) exp(theta/2), theta in the body frame). The gradient is the rod's own force
// computation (forces and body torques with zero velocities, so internal friction vanishes); the
// Hessian is the analytic one of model/rod_system.h (block tridiagonal, exact second derivative
// along that retraction). Newton steps are solved in O(N) by the block Cholesky of
// model/rod_system.h (a Levenberg shift where the Hessian is not positive definite) with a
// backtracking line search on the energy. Steps move the nodes through a retraction that turns each
// chord exactly (rather than adding displacements, which would stretch every turned chord at second
// order): with a stiff stretch or penalty that keeps Newton at 5-10 iterations even for large
// rotations in one load step. Each iteration costs O(N). Rotations are scaled by the mean segment
// length so that all unknowns are lengths and all residuals forces. A residual of ~1e-10 of the
// loads is reached when the stiffnesses allow; stiff stretch or penalty raise the round-off floor
// of the forces (reported) to ~1e-8 of the loads.
#pragma once

#include "corde_sim/rod/rod.h"

namespace corde {

struct StaticOptions {
  // Converged when |residual| <= tolerance * reference force (StaticResult), or when it reaches
  // the round-off floor of the force computation (stiff stretch or penalty set that floor).
  double tolerance = 1e-10;
  int max_iterations = 100;  // Newton iterations per load step
  // Continuation: loads and gravity are ramped in load_steps equal increments from zero, and the
  // kinematic nodes and segments move from where they are to their drives' state in as many
  // increments (free nodes follow, interpolated along the rod, as a predictor). Intermediate
  // steps are solved to sqrt(tolerance).
  int load_steps = 1;
  // Nonzero: planar problem. Nodes move only in the plane through their current position normal
  // to it and segments rotate only about it. Removes out-of-plane zero modes (e.g. the rigid
  // rotation of a pinned-pinned rod about its chord).
  Vec3 plane_normal = Vec3::Zero();
  // Largest move of one unknown per Newton step: displacement in units of the rod length and
  // rotation in radians.
  double max_step = 0.5;
  // The Hessian from central differences of the rod's forces (30 force evaluations per Newton
  // iteration, 60 in static_hessian) instead of the analytic one (model/rod_system.h): a
  // cross-check, and the reference of the benchmark.
  bool finite_difference_hessian = false;
};

struct StaticResult {
  bool converged = false;
  int iterations = 0;            // Newton iterations over all load steps
  int load_steps = 0;            // load steps completed
  int shifted_iterations = 0;    // iterations that needed a Levenberg shift
  int gradient_evaluations = 0;  // force computations, Hessians included
  int unknowns = 0;
  double residual = 0.0;           // |[f; tau / l]| over the free unknowns (N)
  double reference_force = 0.0;    // |external loads, weights and reactions| (N)
  double relative_residual = 0.0;  // residual / reference_force
  double round_off_floor = 0.0;    // estimated residual noise of the force computation (N)
  double energy = 0.0;  // elastic + gravity - work of the force loads at the solution (J)
};

// Solves for the equilibrium at time t under `gravity` and the rod's loads at t (torque loads are
// dead world torques: their work is taken along each step's rotation). Kinematic nodes and
// segments are set to their drives' state at t. Velocities are zeroed. The rod is left in the
// last iterate even when it did not converge.
StaticResult solve_statics(Rod& rod, const Vec3& gravity, double t,
                           const StaticOptions& options = StaticOptions());

}  // namespace corde
