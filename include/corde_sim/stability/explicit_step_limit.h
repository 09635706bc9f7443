// Estimate of the largest stable time step of the explicit (semi-implicit Euler) integrator.
//
// The estimate linearises the rod about a straight, unstressed state, which splits it into three
// families of modes (docs/model.md, "Time-step limits of explicit integration"), and finds the
// highest eigenvalue of each exactly for the discrete rod as it is: its node masses, segment
// inertias, rest lengths, ghost-frame clamps, and with kinematic (driven) nodes and segments
// removed. A Sturm count on the banded mass-scaled stiffness, bisected, gives it in O(N).
//  - stretch: axial node motion, springs K_s/l (continuum estimate 2c/l);
//  - twist: segment rotation about d3, springs C/l (2 c_s/l);
//  - bending-shear: per plane the nodes' transverse motion and the segments' tilt, coupled by
//    the penalty kappa, with the frames' bending springs B/l. This one family holds the modes
//    docs/model.md lists separately (bending through the frames, bending of the centreline, the
//    penalty modes); their 2x2 continuum estimate misses modes at free ends that are up to ~8%
//    higher.
// Internal friction (gamma_t on stretch, gamma_r on twist and tilt, from the old velocity) enters
// as the family's mass-scaled friction matrix D: semi-implicit Euler is stable while
// h^2 K + 2 h D < 4 I, bisected with Sturm counts. For a mode shared by K and D (omega, modal
// damping c) that is h^2 omega^2 + 2 h c < 4, h = (sqrt(c^2 + 4 omega^2) - c) / omega^2, 2/omega
// undamped; Kelvin-Voigt friction (c ~ omega^2 tau) shrinks it to about 2/(omega^2 tau). The
// friction need not damp K's top mode: gamma_r on the tilts (half the twist's inertia) can limit
// while K's top bending-shear mode moves the nodes. The smallest step of the three families wins.
#pragma once

#include <cmath>
#include <string>

#include "corde_sim/rod/rod.h"

namespace corde {

class World;

struct StabilityEstimate {
  double time_step = 0.0;  // predicted critical step (s): the minimum of the three below
  double stretch = 0.0;    // critical step of the stretch family (s)
  double twist = 0.0;      // critical step of the twist family (s)
  double bending = 0.0;    // critical step of the bending-shear family (s)
  double omega_max = 0.0;  // highest undamped angular frequency over all families (rad/s)
  std::string limiting;    // "stretch", "twist" or "bending-shear"
};

// Uses the rod's actual section (B, C, K_s, kappa, gamma_t, gamma_r), masses, inertia, rest
// lengths, drives and ghost frames; the current shape is not used (curvature is neglected).
StabilityEstimate estimate_stability(const Rod& rod);

// estimate_stability(rod).time_step. Run with about 0.8 of it for margin.
double critical_time_step(const Rod& rod);

// The explicit step linearised about the rod's CURRENT state rather than the straight rest state.
// Large deformation moves the limit: the coupling penalty l kappa (1 - t.d3) stiffens the nodes'
// transverse motion as kappa l / |d|^2, so an element compressed to half its length has four
// times the stiffness there (the limit of a collapsing soft rod, docs/charts.md, "Stability
// map"); tension adds its geometric stiffness, bent and sheared frames tilt the blocks. Here K is
// the exact Hessian of the elastic energy (model/rod_system.h, every second-order term) at the
// current positions and orientations, M the node masses and the segments' body inertias, D the
// internal friction in the current tangents and frames; kinematic nodes and segments are removed.
// The step is the largest h with 4 M - h^2 K - 2 h D positive definite (block Cholesky, bisected;
// O(N) per factorisation, about 100 of them). The gyroscopic terms and the skew part of the
// torque Jacobian off equilibrium are neglected. At the rest state it equals
// estimate_stability(rod).time_step.
struct StateStabilityEstimate {
  double time_step = 0.0;       // critical step about the current state (s); inf: no limit
  double omega_max = 0.0;       // sqrt of the top eigenvalue of M^-1 K (rad/s)
  int block = -1;               // node / segment index where the top mode of M^-1 K is largest
  double rotation_share = 0.0;  // part of that mode's mass-weighted norm^2 on the rotations
};
StateStabilityEstimate estimate_stability_at_state(const Rod& rod);

// The smaller of critical_time_step(rod) and estimate_stability_at_state(rod).time_step (the
// rest value where they agree to round-off): what `time_step: auto` (at the start) and the
// stability guard (at a rollback) use. Costs about 100 factorisations of the rod's 6x6 blocks.
double state_critical_time_step(const Rod& rod);

// The explicit step limit of a world: the smallest over its rods, the one function behind
// time_step: auto, the scene's stability warning, the guard's choice between halving and the
// implicit method, ~configure's margin and the element probes. `at_state` false: each rod's
// critical_time_step (the straight rest state); true: its state_critical_time_step (the lower
// of that and the limit about its current state: a rod built bent, stretched or crumpled).
struct WorldStepLimit {
  double time_step = INFINITY;  // s; a rod's NaN estimate wins (reported, not hidden)
  int rod = -1;                 // the limiting rod (-1: no rods)
  std::string limiting;         // its family ("stretch", ...) or "start shape" (the state's)
};
WorldStepLimit explicit_step_limit(const World& world, bool at_state);
// `rotational_inertia_scale: auto`: the smallest rotary-inertia scale (Rod::
// set_rotational_inertia_scale, >= 1) at which the bending-shear family's critical step reaches
// 0.99 of the next limit, the stretch or twist family's (or, when the penalty on the nodes alone
// limits below those, 0.99 of what any scale can give). 1 when the coupling penalty does not
// limit. The rod's own scale is ignored. Lifting to the stretch limit l sqrt(rho / E_s) takes
// 1.5 to 2 times s = (l / r)^2 kappa / K_s at coarse N, which shifts a bending mode of wavenumber
// k by as many times -(kappa / K_s) (k l)^2 / 8: the order of the discrete rod's own O((k l)^2)
// frequency error (docs/model.md, "Rotary-inertia scaling").
double lifting_inertia_scale(const Rod& rod);

}  // namespace corde
