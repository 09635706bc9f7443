// Backward (implicit) Euler step of one rod on the shared rod system (model/rod_system.h): stable
// at steps far beyond the explicit limit. World::step runs it for Integrator::kImplicitEuler, with
// contacts applied through respond().
//
// The step from t to t + h minimises the incremental potential
//   Phi = sum_i m_i/(2h^2) |x_i - x_i^n - h v_i^n|^2
//       + sum_s 1/(2h^2) (theta_s - h w_s^n)^T I_s (theta_s - h w_s^n) + E(x, q) + D(x, q) - W
// over the node positions x and the segment rotations q = q^n (x) exp(theta/2) (theta the body
// rotation vector over the step), E the elastic energy and gravity at t + h, W the work of the
// loads, D the dissipation potential of internal friction and drag. Its stationarity conditions
// are backward Euler for the nodes and, to first order in theta, for the rotations (the
// gyroscopic term w x I w is left out: for the thin sections of rods it is small and its effect
// is bounded). Newton iterations on the increments (dx, dtheta) use the exact Hessian plus M/h^2
// and I/h^2 (quadratic convergence); for an iteration where that sum is not positive definite (a
// compressed rod buckling where it lands), the same with its inertia terms scaled by 1 + tau, the
// smallest tau of 1e-3 x 4^k (up to 1e3) that makes it definite, and failing that its positive
// semi-definite variant (which converges only linearly); solved by the O(N) block Cholesky, with
// a backtracking line search on Phi. The contact response uses the last iteration's
// factorisation (unless shifted) while its answer z to the impulses' loads b keeps
// z^T M z / h^2 <= 2 b . z (a definite matrix, A >= M/h^2, keeps it within b . z), else the
// definite variant at the step's result: the exact matrix may be near singular and answer an
// impulse with a huge motion. New velocities are (x - x^n)/h and theta/h.
//
// Dissipation, linear in the step's velocities with directions taken at the step's start (so it
// is quadratic in the unknowns and never adds energy): internal friction along each chord's
// tangent (gamma_t / l (t . (dx_{s+1} - dx_s))^2 / 2h) and on the world angular velocity
// difference of neighbouring segments (gamma_r / l |R_{s+1} theta_{s+1} - R_s theta_s|^2 / 2h),
// both zero for rigid motion as in the explicit force; air drag with its coefficients at the
// step's start velocity. Loads: gravity, dead forces and torques at t + h; follower loads, the
// rod's external forces and torques, all taken in the world at the step's start and held.
// Kinematic nodes and segments are set to their drives at t + h and held; line and plane
// constraints on nodes and axis constraints on segments restrict their increments by
// projection. Each support records its reaction (the residual force or torque it takes).
//
// Second order (BDF2, set_second_order(true); Integrator::kBdf2): the same minimisation with the
// step h replaced by the effective step b = 2h/3 and the start state by the BDF2 combination of
// the last two states:
//   x^{n+1} - x~ = b v^{n+1},   x~ = (4 x^n - x^{n-1}) / 3,
//   M (v^{n+1} - v~) = b f^{n+1}, v~ = (4 v^n - v^{n-1}) / 3,
// so x_hat = x~ + b v~ replaces x^n + h v^n and 1/h^2, 1/h become 1/b^2, 1/b. Rotations are
// written in local coordinates about the current orientation q^n: theta = log(q^n^-1 q^{n+1})
// and xi = log(q^n^-1 q^{n-1}) (body frame of q^n), theta + xi/3 = b w^{n+1}, and the body
// angular velocities combine as the node velocities (Euler's equations are in body components).
// Dissipation takes the BDF2 rates (x - x~)/b and (theta + xi/3)/b; the directions, drag
// coefficients and follower loads held over the step are taken at the state extrapolated to
// t + h (2 y^n - y^{n-1}), not at the start (which would cost an order). The mapping of the
// rotational inertia term to the rotation increment (the J_r^-T factor, also in backward Euler)
// leaves an O(h) error on it whose size is the rotational inertia's share of the motion,
// I w x dw/dt; for rods (I of order m r^2) it is far below the second-order error.
// Without a usable history the step is one backward-Euler step: the first step, a different h,
// a different number of nodes, a change of the drives (a grasp taken or let go), and any state
// not exactly the one the last step left (a reset, a configure, a state set from outside; the
// guard's rollback restores the snapshot's history, and its retry at half the step restarts);
// BDF2 then starts from that step.
#pragma once

#include <vector>

#include "corde_sim/model/rod_system.h"

namespace corde {

struct ImplicitOptions {
  int max_iterations = 20;  // Newton iterations per step
  // Converged when |grad Phi| (forces, torques / mean segment length) <= tolerance * the rod's
  // momentum and weight scale sum_i m_i (|g| + |v_i| / h), or reaches the round-off floor of
  // the forces (stiff stretch and penalty set it).
  double tolerance = 1e-8;
  // ... or below this fraction of the predicted contact forces (their sum of magnitudes, torques /
  // mean segment length), the accuracy to which the contact solve resolves its impulses: its
  // rounds stopped once no contact closed past its target by more than 1e-3 of the radius (at rest
  // now 1e-4: ContactSettings::implicit_tolerance_min), and a rope lying still on 101 contacts then
  // saw its impulses change by about 1e-4 of the largest from step to step, 1e-4 / sqrt(101) =
  // 1e-5 on this measure (a 2-norm against a sum of magnitudes).
  // Below it a Newton iteration chases that noise at every step; it moves a node by at most h^2/m
  // times it.
  double prediction_tolerance = 1e-5;
  // Reuse of the factorised Newton matrix (a chord iteration): it is kept from an earlier
  // iteration or step while no element's direction and no segment's orientation has turned by
  // more than this angle (rad) since it was factorised, and the step size and the supports are
  // the same, and the rod's parameters unchanged. An iteration on a kept factor that does not cut
  // the residual to a quarter makes the next one factorise afresh, and Newton iterations then
  // factorise every time until a step converges in one or none (a moving rod converges faster with
  // fresh matrices; a resting one, whose contact response needs the matrix at every step, keeps
  // one). 0: factorise at every iteration (Newton's method proper). The result meets the same
  // tolerance either way; only the path to it changes.
  double reuse_factor = 0.01;
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
  // Advances the rod from t to t + h (drives set at t + h). The rod is left at the last iterate
  // when Newton did not converge. predicted: node impulses expected from contacts over the step
  // (the last step's), applied as forces p / h so that the step starts near its result with
  // contacts; respond() takes the total impulses and applies only the difference.
  // predicted_torques: the same for torque impulses on the segments (world, one per segment).
  ImplicitResult step(Rod& rod, double t, double h, const Vec3& gravity,
                      const std::vector<Vec3>* predicted = nullptr,
                      const std::vector<Vec3>* predicted_torques = nullptr);
  // BDF2 (true) or backward Euler (false, the default) from the next step on.
  void set_second_order(bool on) { bdf2_ = on; }
  bool second_order() const { return bdf2_; }
  // Whether the last step was a BDF2 step (false: backward Euler, the start or restart).
  bool last_step_second_order() const { return used_bdf2_; }
  // Forgets the history: the next step is a backward-Euler step.
  void reset_history() { have_history_ = false; }
  // Takes the last step again from its start state, as a backward-Euler step (no prediction):
  // a BDF2 step moves the rod by a third of its last step's motion whatever the contact impulses
  // do (x = (4 x^n - x^{n-1}) / 3 + 2h/3 v), so a rod hitting a contact is stepped this way
  // (ImplicitStepper::retake, from the contact solve).
  ImplicitResult restep_first_order(Rod& rod, double t, double h, const Vec3& gravity);

  // After step(): sets the rod to the step's result plus the response to node impulses p (N s,
  // world, one per node; applied as forces p / b over the step, b the step's effective step:
  // h for backward Euler, 2h/3 for BDF2), linearised at the step's end with its Hessian:
  // dx = A^-1 p / b, A = M / b^2 + the Hessian of E + D. The rotations follow through the
  // coupling of A. Kinematic and constrained items respond only where they are free. Calling it
  // again replaces the previous response. torque_impulses: optionally also torque impulses on the
  // segments (N m s, world, one per segment; contact friction's moment), applied as torques
  // T / b held over the step as the step applies loads (less the predicted ones).
  void respond(Rod& rod, const std::vector<Vec3>& impulses,
               const std::vector<Vec3>* torque_impulses = nullptr);
  // The node velocity changes that these impulses make, without changing the rod (dv = A^-1 p /
  // b^2): for a change of the impulses, the difference of respond()'s velocities (which takes the
  // prediction out of the totals; a change carries none of it).
  void response(const Rod& rod, const std::vector<Vec3>& impulses, std::vector<Vec3>* dv,
                const std::vector<Vec3>* torque_impulses = nullptr);
  // The node blocks of the response's compliance, dv = C p (the operator response() applies,
  // m/s per N s): diag[i] = C_ii, lower[i] = C_{i+1,i}, from the diagonal and first subdiagonal
  // blocks of A^-1 by selected inversion of the factorisation the response uses (kept while that
  // factorisation is). Held nodes' blocks are zero. False when no factorisation is usable.
  bool node_compliance(const Rod& rod, std::vector<Mat3>* diag, std::vector<Mat3>* lower);
  // The last step's effective step b (s).
  double effective_step() const { return beta_; }
  bool has_prediction() const { return !predicted_.empty() || !predicted_torques_.empty(); }
  // The state at the start of the last step.
  const std::vector<Vec3>& start_positions() const { return x0_; }
  const std::vector<Vec3>& start_velocities() const { return v0_; }
  const ImplicitOptions& options() const { return opt_; }
  // Factorisations of the Newton matrix so far (for tests and benchmarks of reuse_factor).
  long factorisations() const { return factorisations_; }
  void set_options(const ImplicitOptions& o) { opt_ = o; }

 private:
  class Iterations;  // the Newton iterations of step() (linalg/newton.h)
  void setup_supports(Rod& rod, double t1);
  void setup_dissipation(const Rod& rod, double h);
  void setup_loads(const Rod& rod, double t1);
  double merit(const Rod& rod, const RodSystem& sys, double h) const;
  void gradient(const Rod& rod, const RodSystem& sys, double h, Eigen::VectorXd* g);
  void assemble(const Rod& rod, const RodSystem& sys, double h);
  void project_gradient(Eigen::VectorXd* g) const;
  void record_reactions(Rod& rod);
  // A factorisation for the contact response at the step's result (exact_ok: the last Newton
  // iteration's, even if it was the exact Hessian's).
  bool ensure_factor(const Rod& rod, bool exact_ok = false);
  // The response z_ to the impulses: on the last factorisation if its answer is bounded
  // (response_bounded), else on the definite variant's. totals: the impulses are totals, from
  // which the predicted ones (already in the step) come out; else a change of them.
  bool solve_response(const Rod& rod, const std::vector<Vec3>& impulses,
                      const std::vector<Vec3>* torque_impulses, bool totals);
  bool response_bounded(const Rod& rod) const;
  // Assembles and factorises at the rod's state (false: not positive definite).
  bool refactor(const Rod& rod, const RodSystem& sys, double h);
  // Whether the kept factorisation may stand for the matrix at the rod's state now.
  bool factor_reusable(const Rod& rod);
  // The rod's parameters that enter the Newton matrix (section, drag, rest lengths, masses,
  // inertia, rest strains, the clamps' ghost frames; the velocities under quadratic drag),
  // flattened, to tell a configured rod from the one factorised.
  static void parameters(const Rod& rod, std::vector<double>* out);
  void solve_impulses(const std::vector<Vec3>& impulses, const std::vector<Vec3>* torque_impulses,
                      bool totals);  // into z_
  bool history_usable(const Rod& rod, double h) const;
  void remember_end(const Rod& rod);

  ImplicitOptions opt_;
  bool bdf2_ = false, used_bdf2_ = false;
  bool force_first_ = false;  // restep_first_order: this step is backward Euler
  double beta_ = 0.0;         // the step's effective step: h, or 2h/3 for BDF2
  std::vector<Vec3> x0_, v0_, w0_, xhat_, xs_;
  std::vector<Quat> q0_, qk_;
  // The origin of the step's node velocities, v = (x - xt_) / beta_ (x^n, or BDF2's x~), and per
  // segment the offset of its rotation, b w = theta + off_ (0, or xi / 3).
  std::vector<Vec3> xt_, off_;
  std::vector<Vec3> xx_, vx_;  // BDF2: positions and velocities extrapolated to the step's end
  std::vector<Quat> qx_;       // and orientations
  // History for BDF2: the last step's start state and h, and the state it left the rod in (the
  // next step uses the history only from exactly that state), and its drives.
  bool have_history_ = false;
  double h_last_ = 0.0;
  std::vector<Vec3> xp_, vp_, wp_, xe_, ve_, we_;
  std::vector<Quat> qp_, qe_;
  std::vector<int> drives_last_;
  std::vector<Vec3> gth_;    // per segment: d Phi / d theta (scratch)
  std::vector<int> drives_;  // scratch: the drives' items and kinds
  std::vector<Vec3> what_;   // h w^n per segment (body); BDF2: b w~ - xi / 3
  std::vector<Vec3> theta_;  // the current iterate's rotation over the step, per segment (body)
  // Per 3-component unknown u (node i: 2i, segment s: 2s + 1): 0 free, 1 held, 2 projected by
  // proj_[u] (the directions it may move in).
  std::vector<signed char> kind_;
  std::vector<Mat3> proj_;
  // Dissipation frozen at the step's start.
  std::vector<Vec3> tangent_;   // per segment: unit chord
  std::vector<double> chord0_;  // per segment: t . (xt_{s+1} - xt_s)
  std::vector<Mat3> rot0_;      // per segment: R^n (BDF2: R_p J_r(theta_p), see step())
  std::vector<Mat3> drag_;      // per node: drag matrix D_i (N s / m)
  bool friction_t_ = false, friction_r_ = false, drag_on_ = false;
  // Loads held over the step (world): forces on nodes, torques on segments.
  std::vector<std::pair<int, Vec3>> forces_, torques_;
  std::vector<Vec3> predicted_;          // node impulses the step included (empty: none)
  std::vector<Vec3> predicted_torques_;  // and segment torque impulses (empty: none)
  BlockTridiag a_;
  BlockTridiagSolver solver_;
  bool factored_ = false;  // solver_ holds a factorisation usable for this step
  // The state solver_ was factorised at, to decide whether it can be kept (reuse_factor).
  bool have_factor_ = false;
  bool factor_definite_ = false;  // solver_ holds the definite variant (the contact response's)
  // The inertia terms of the assembled matrix are scaled by 1 + shift_ (0 but while Newton shifts
  // an indefinite exact Hessian); factor_shifted_: the factorisation is such a shifted one.
  double shift_ = 0.0;
  bool factor_shifted_ = false;
  double factor_beta_ = 0.0;
  std::vector<Vec3> factor_x_;
  std::vector<Quat> factor_q_;
  std::vector<signed char> factor_kind_;
  std::vector<Mat3> factor_proj_;
  std::vector<double> factor_params_, params_;  // the rod's parameters then and now (scratch)
  long factorisations_ = 0;
  // Selected inverse of the factorisation numbered inverse_of_ (node_compliance).
  std::vector<Mat6> inv_diag_, inv_lower_;
  long inverse_of_ = -1;
  bool chord_ok_ = true;  // Newton may iterate on a kept factorisation (off after one failed)
  Eigen::VectorXd g_, g_trial_, d_, z_, rhs_;
  Eigen::VectorXd g_raw_, g_raw_trial_;  // g_ and g_trial_ before the supports' projection
  // The step's result without contacts (for respond()).
  std::vector<Vec3> x_free_, v_free_, w_free_;
  std::vector<Quat> q_free_;
};

}  // namespace corde
