// The rod's potential energy as a function of its unknowns, with the analytic gradient and
// Hessian, shared by statics and implicit integration.
//
// Unknowns: per node i a displacement dx_i (world frame) and per segment s an incremental body
// rotation theta_s, the orientation moving as q_s <- q_s (x) exp(theta_s / 2) (the rotation by
// |theta_s| about theta_s in the segment's own frame). They are ordered in blocks of six,
// (x_0, theta_0, x_1, theta_1, ..., x_N, [unused]), so vector entry 6k + c is component c of node
// k (c < 3) or of segment k's rotation (c >= 3); the last block's rotation slot is unused and
// kept fixed. Every energy term couples only neighbouring blocks, so the Hessian is block
// tridiagonal with 6x6 blocks whatever N.
//
// The Hessian is the exact second derivative of E(x + dx, q (x) exp(theta/2)) at dx = 0,
// theta = 0: symmetric everywhere. The Jacobian of the body torques along the same retraction
// differs from it by a skew part, (1/2) [g_theta]x per segment (g_theta the body gradient), which
// vanishes at equilibrium; Newton converges quadratically with either, and the symmetric one can
// be factored by Cholesky.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "corde_sim/linalg/block_tridiag.h"
#include "corde_sim/math/types.h"
#include "corde_sim/rod/rod.h"

namespace corde {

// Energy terms, to select some of them (tests check each term's blocks on its own).
enum SystemTerm : unsigned {
  kStretchTerm = 1u,
  kCouplingTerm = 2u,
  kBendTwistTerm = 4u,  // interior elements and ghost-frame clamps
  kGravityTerm = 8u,
  kLoadTerm = 16u,  // dead force and torque loads of the rod at time t, times load_scale
  kAllTerms = 31u,
};

// The potential energy of one rod at its current state. Internal friction, drag and external
// forces are not part of it (they are not conservative); follower loads are ignored here.
struct RodSystem {
  const Rod* rod = nullptr;
  Vec3 gravity = Vec3::Zero();
  double t = 0.0;           // time at which the loads are evaluated
  double load_scale = 1.0;  // factor on the loads (continuation)
  unsigned terms = kAllTerms;
  // false: the exact Hessian. true: a positive semi-definite variant (the implicit step's contact
  // response, and its Newton iterations where the exact one is not definite), which
  // keeps only the parts that cannot turn negative: Gauss-Newton for the coupling and bending
  // (J^T K J of their residuals t - d3 and u - uhat) and the stretch's geometric stiffness only
  // under tension. It equals the exact Hessian at the rest state. The exact one is indefinite
  // where frames are sheared against their chords: in the rotation chart the penalty's second
  // order cross terms lower the twist curvature by about l kappa gamma^2 / 4 (gamma the shear
  // angle), more than the twist stiffness C/l for a steel wire at gamma of a few 0.01 rad.
  bool definite = false;
  // Stand-ins for the rod's section and node masses (null: the rod's own). Every term is linear in
  // its constant (B, C, K_s, kappa, the node masses), so the gradient with the constants' rates
  // d/dp in their place is d(gradient)/dp: how statics' sensitivity (statics/static_sensitivity.h)
  // gets it without differencing.
  const Section* section = nullptr;
  const std::vector<double>* node_masses = nullptr;

  int blocks() const { return rod->num_nodes(); }
  int size() const { return 6 * blocks(); }
  static int node_index(int i) { return 6 * i; }
  static int segment_index(int s) { return 6 * s + 3; }

  // Elastic energy, gravity and the potential -F.x of dead force loads (J). Dead torques have no
  // potential on the rotations (their work depends on the path); they enter gradient() only.
  double energy() const;
  // dE/d(unknowns) at the current state (size() entries; the unused slot is 0). For the nodes it
  // is minus the force, for the segments minus the body torque that Rod::compute_forces gives
  // with zero velocities.
  void gradient(Eigen::VectorXd* g) const;
  // The symmetric Hessian at the current state, overwriting h (resized to blocks()). The unused
  // slot is left zero; fix() it (and the kinematic items) before factoring.
  void hessian(BlockTridiag* h) const;
};

// Analytic second derivatives of the single terms, in the unknowns above (exposed for tests).
// Stretch of the chord d = x_{i+1} - x_i: d^2 V / dd^2.
// With definite = true the PSD variants above.
Mat3 stretch_hessian(const Vec3& d, double rest, double ks, bool definite = false);
// Coupling of chord d with segment orientation q: blocks (d, d), (d, theta) and (theta, theta).
void coupling_hessian(const Vec3& d, const Quat& q, double rest, double kappa, Mat3* hdd, Mat3* hdt,
                      Mat3* htt, bool definite = false);
// Bending and twist between frames a and b: blocks (a, a), (a, b) and (b, b) in the body
// rotations of a and b.
void bend_twist_hessian(const Quat& a, const Quat& b, double rest, const Vec3& k, const Vec3& uhat,
                        Mat3* haa, Mat3* hab, Mat3* hbb, bool definite = false);

// Gravity gb (body frame) on a mass at offset d from a node, fixed to the segment: d^2/dtheta^2
// of -mass gb.(exp(theta) d) at theta = 0 (with definite = true its positive semi-definite part).
Mat3 mass_offset_hessian(const Vec3& gb, const Vec3& d, double mass, bool definite = false);

}  // namespace corde
