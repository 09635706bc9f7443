// Choosing a world's time step and integrator from the scene itself (scene keys time_step: auto
// and integrator: auto, docs/scene_format.md "Automatic choices").
//
// Explicit methods (semi_implicit_euler, split_rotation): 0.8 of the estimated stability limit
// (stability/explicit_step_limit.h), the largest step they can take.
// The implicit method (implicit_euler) is stable at any step; its step is chosen for accuracy:
// the smallest of
//  - the frame: 2 ms (a robot controller's period; nothing finer is looked at);
//  - duration / 50 (a short scene still gets steps to show);
//  - 0.0335 / omega_1 per rod: backward Euler damps a mode of frequency omega by
//    1 / sqrt(1 + (h omega)^2) per step, about exp(-pi h omega) per period, so h omega <= 0.0335
//    keeps the loss of the rod's lowest mode below 10% of its amplitude per period. omega_1 is the
//    lowest bending mode of a uniform beam of the rod's B, mass per length and length with its
//    supports (one end held: (1.875/L)^2 sqrt(B/mu); otherwise free-free, (4.730/L)^2
//    sqrt(B/mu)), or the pendulum frequency sqrt(|g|/L) of a held rod if higher. For bdf2,
//    whose amplitude factor per step is about 1 - (h omega)^4 / 4 (far less damping) but whose
//    phase lags by about (h omega)^3 / 3 per step, 0.2 / omega_1: the mode's period is kept to
//    1.3% and it loses 1.1% of its amplitude per period;
//  - the drives: a driven node moves at most half an element per step (its speed, or the mean
//    speed between keyframes), a spinning or keyframed segment turns at most 0.1 rad per step,
//    and a ramp or keyframe interval takes at least 10 steps.
// integrator: auto compares the work per simulated second of the explicit method at its step and
// the implicit one at its step, each counted over a short trial on a copy of the world (32
// explicit, 8 implicit steps): element evaluations, Newton iterations times their weight per
// element, contacts times theirs. Counted, not timed, so that the same scene chooses the same on
// any machine, idle or loaded.
#pragma once

#include <string>

#include "corde_sim/scene/scene.h"

namespace corde {

constexpr double kFrameStep = 2e-3;  // s: the default frame of the implicit step

struct ImplicitStepChoice {
  double time_step = kFrameStep;  // s
  std::string why;                // which bound set it, with its numbers
};

// The implicit method's step for the scene (its rods, drives, grasps, gravity and duration).
ImplicitStepChoice implicit_time_step(const Scene& scene);

// 0.8 of the smallest estimated stability limit of the world's rods (0 if not positive finite),
// and the limiting rod and family in *why.
double explicit_time_step(const World& world, std::string* why);

struct IntegratorChoice {
  Integrator integrator = kDefaultIntegrator;
  double time_step = 0.0;  // s, the chosen method's
  // Each method's step (s) and its counted work per step, in element evaluations (0: no trial).
  double explicit_step = 0.0, implicit_step = 0.0;
  double explicit_cost = 0.0, implicit_cost = 0.0;
  std::string reason;
};

// integrator: auto. `given_step` > 0: the scene's time_step (explicit if it is within the
// explicit limit, else implicit, without a trial); 0: each method at its own step, its work
// counted over a trial. Reads no clock: the choice depends on the scene only.
IntegratorChoice choose_integrator(const Scene& scene, double given_step);

}  // namespace corde
