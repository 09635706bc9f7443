// Backward (implicit) Euler step of one rod without contacts: a first stiff-stable integrator on
// the shared rod system (rod_system.h). Not wired into scenes yet.
//
// The step from t to t + h minimises the incremental potential
//   Phi = sum_i m_i/(2h^2) |x_i - x_i^n - h v_i^n|^2
//       + sum_s 1/(2h^2) (theta_s - h w_s^n)^T I_s (theta_s - h w_s^n) + E(x, q)
// over the node positions x and the segment rotations q = q^n (x) exp(theta/2) (theta the body
// rotation vector over the step), E the elastic energy, gravity and dead loads at t + h. Its
// stationarity conditions are backward Euler for the nodes and, to first order in theta, for the
// rotations (the gyroscopic term w x I w is left out: for the thin sections of rods it is small
// and its effect is bounded). Newton iterations on the increments (dx, dtheta) use the positive
// semi-definite Hessian variant plus M/h^2 and I/h^2, solved by the O(N) block Cholesky, with a
// backtracking line search on Phi. New velocities are (x - x^n)/h and theta/h.
//
// Loads: gravity, dead force and torque loads at t + h, and the rod's external forces and
// torques, all held constant over the step. Not yet: internal friction (the step damps high
// frequencies numerically instead), drag, follower loads and line/plane/hinge constraints
// (refused), contacts.
#pragma once

#include <vector>

#include "corde_sim/rod_system.h"

namespace corde {

struct ImplicitOptions {
  int max_iterations = 20;  // Newton iterations per step
  // Converged when |grad Phi| (forces, torques / mean segment length) <= tolerance * the rod's
  // momentum and weight scale sum_i m_i (|g| + |v_i| / h), or reaches the round-off floor of
  // the forces (stiff stretch and penalty set it).
  double tolerance = 1e-8;
};

struct ImplicitResult {
  bool converged = false;
  int iterations = 0;
  double residual = 0.0;   // |grad Phi| at the end (N)
  double reference = 0.0;  // the scale it is compared with (N)
};

class ImplicitEuler {
 public:
  explicit ImplicitEuler(ImplicitOptions options = ImplicitOptions()) : opt_(options) {}
  // Advances the rod from t to t + h (drives set at t + h). Throws std::invalid_argument for a
  // rod with constraints or follower loads. The rod is left at the last iterate when Newton did not
  // converge.
  ImplicitResult step(Rod& rod, double t, double h, const Vec3& gravity);

 private:
  double merit(const Rod& rod, const RodSystem& sys, double h) const;
  void gradient(const Rod& rod, const RodSystem& sys, double h, Eigen::VectorXd* g);

  ImplicitOptions opt_;
  std::vector<Vec3> x0_, xhat_, xk_;
  std::vector<Quat> q0_, qk_;
  std::vector<Vec3> what_;   // h w^n per segment (body)
  std::vector<char> fixed_;  // per unknown of the block layout
  BlockTridiag a_;
  BlockTridiagSolver solver_;
  Eigen::VectorXd g_, g_trial_, d_;
};

}  // namespace corde
