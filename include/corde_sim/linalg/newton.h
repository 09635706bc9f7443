// Damped Newton iterations with a backtracking line search, shared by the implicit step
// (integrators/implicit_step.h) and statics (statics/statics.h).
//
// The solver drives a problem that owns its state and its unknowns: the problem supplies the
// Newton direction (its own matrix, factorisation and fallbacks: a Levenberg shift for statics, a
// definite variant or a kept factorisation for the implicit step), moves its state along the
// direction by its own retraction, and evaluates its merit (an energy whose gradient is minus the
// residual) and its residual. The solver decides the step length and when to stop, the same way
// for both: a full step that cuts the residual enough is taken at once (optional); otherwise
// Armijo's sufficient decrease of the merit, or, where the merit's change is lost in its
// round-off, a drop of the residual.
#pragma once

namespace corde {

struct LineSearchOptions {
  double armijo = 1e-4;  // sufficient decrease: phi(alpha) <= phi(0) + armijo alpha slope
  int max_trials = 30;   // step lengths tried: 1, 1/2, 1/4, ...
  // > 0: a full step whose residual is at most this fraction of the iterate's is taken without
  // evaluating the merit (Newton's step near the solution, where the merit costs the most).
  double full_step_cut = 0.0;
  // Refuse a direction along which the merit does not decrease (slope >= 0 or NaN).
  bool require_descent = false;
  // Armijo tested on the change, phi(alpha) - phi(0) <= armijo alpha slope, which a trial that
  // leaves phi unchanged never passes; else as phi(alpha) <= phi(0) + armijo alpha slope, which it
  // passes once that term is below phi's last digit (the implicit step's form, kept for its
  // arithmetic).
  bool armijo_on_change = false;
};

// The merit at the iterate and the size of its round-off, kept across iterations (an accepted
// step's merit is the next iterate's). known = false: evaluated when first needed.
struct MeritAtIterate {
  bool known = false;
  double phi = 0.0;
  double noise = 0.0;  // |phi(alpha) - phi| <= noise counts as no change
};

enum class LineSearchResult { kFullStep, kAccepted, kRejected };

// What the line search needs of a problem. The iterate is the base state; moves are along the
// problem's current direction d.
class LineSearchProblem {
 public:
  virtual ~LineSearchProblem() = default;
  // Sets the state to the base moved by alpha d.
  virtual void move(double alpha) = 0;
  // The merit at the current state (alpha: the one of the last move).
  virtual double merit(double alpha) = 0;
  // The merit at the base and its round-off (the state is at a trial: the problem may move to the
  // base and back).
  virtual void base_merit(MeritAtIterate* m) = 0;
  // The residual at the current state, kept as the trial's; returns its norm.
  virtual double trial_residual() = 0;
  // The trial's residual becomes the iterate's (the state stays where it is).
  virtual void accept_trial() = 0;
};

// Backtracking along the problem's direction from the base, whose residual norm is r0 and the
// merit's derivative along the direction `slope`. On acceptance the state is the accepted point
// and its residual the iterate's; on rejection the state is at the last trial (the caller
// restores the base). m: the merit at the base, updated to the accepted point's (full steps
// leave it unknown).
LineSearchResult line_search(LineSearchProblem* p, double slope, double r0,
                             const LineSearchOptions& options, MeritAtIterate* m);

// What the Newton loop needs of a problem besides the line search.
class NewtonProblem : public LineSearchProblem {
 public:
  enum class Check { kContinue, kConverged, kStop };
  enum class Retry { kSameIteration, kNextIteration, kStop };
  // Before an iteration, with the iterate's residual norm: converged, give up, or iterate.
  virtual Check check(double residual) = 0;
  virtual double residual_norm() = 0;
  // The Newton direction at the iterate for the attempt-th try of this iteration (0, 1, ...),
  // and the merit's slope along it; false: none (the solve stops). Also saves the base state.
  virtual bool direction(int attempt, double* slope) = 0;
  // After a rejected line search: restores the base state and says what to do next.
  virtual Retry rejected(int attempt) = 0;
  // After an accepted line search (attempts made in this iteration: attempt + 1).
  virtual void accepted(int attempt) { (void)attempt; }
};

struct NewtonOptions {
  int max_iterations = 20;
  LineSearchOptions line_search;
  // The merit of an accepted point stands for the next iterate's (false: asked of the problem at
  // every line search, for merits measured from the iterate).
  bool keep_merit = true;
};

enum class NewtonStop { kConverged, kStopped, kIterationLimit };

struct NewtonOutcome {
  NewtonStop stop = NewtonStop::kIterationLimit;
  int iterations = 0;  // directions computed (iterations counted by the loop)
};

// Newton iterations from the problem's current state. m: the merit at the iterate, carried
// between solves by the caller if it wishes (unknown by default).
NewtonOutcome newton_solve(NewtonProblem* p, const NewtonOptions& options,
                           MeritAtIterate* m = nullptr);

}  // namespace corde
