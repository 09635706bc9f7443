#include "corde_sim/linalg/newton.h"

#include <cmath>

namespace corde {

LineSearchResult line_search(LineSearchProblem* p, double slope, double r0,
                             const LineSearchOptions& o, MeritAtIterate* m) {
  if (o.require_descent && !(slope < 0.0)) return LineSearchResult::kRejected;
  double alpha = 1.0;
  for (int trial = 0; trial < o.max_trials; ++trial, alpha *= 0.5) {
    p->move(alpha);
    bool have_residual = false;
    double r = 0.0;
    if (trial == 0 && o.full_step_cut > 0.0) {
      r = p->trial_residual();
      have_residual = true;
      if (r <= o.full_step_cut * r0) {
        p->accept_trial();
        m->known = false;  // not evaluated at the new iterate
        return LineSearchResult::kFullStep;
      }
    }
    if (!m->known) {
      p->base_merit(m);
      m->known = true;
    }
    const double phi = p->merit(alpha);
    if (!std::isfinite(phi)) continue;
    const bool armijo = o.armijo_on_change ? phi - m->phi <= o.armijo * alpha * slope
                                           : phi <= m->phi + o.armijo * alpha * slope;
    if (armijo) {
      if (!have_residual) p->trial_residual();
      p->accept_trial();
      m->phi = phi;
      return LineSearchResult::kAccepted;
    }
    // Near the solution the change of the merit is lost in its round-off: a step that lowers
    // the residual is taken instead.
    if (std::abs(phi - m->phi) <= m->noise) {
      if (!have_residual) r = p->trial_residual();
      if (r < r0) {
        p->accept_trial();
        m->phi = phi;
        return LineSearchResult::kAccepted;
      }
    }
  }
  return LineSearchResult::kRejected;
}

NewtonOutcome newton_solve(NewtonProblem* p, const NewtonOptions& o, MeritAtIterate* merit) {
  MeritAtIterate local;
  MeritAtIterate* m = merit ? merit : &local;
  NewtonOutcome out;
  for (int it = 0; it < o.max_iterations; ++it) {
    const double r = p->residual_norm();
    const NewtonProblem::Check c = p->check(r);
    if (c == NewtonProblem::Check::kConverged) {
      out.stop = NewtonStop::kConverged;
      return out;
    }
    if (c == NewtonProblem::Check::kStop) {
      out.stop = NewtonStop::kStopped;
      return out;
    }
    ++out.iterations;
    bool next = false;
    for (int attempt = 0; !next; ++attempt) {
      double slope = 0.0;
      if (!p->direction(attempt, &slope)) {
        out.stop = NewtonStop::kStopped;
        return out;
      }
      if (!o.keep_merit) m->known = false;
      if (line_search(p, slope, r, o.line_search, m) != LineSearchResult::kRejected) {
        p->accepted(attempt);
        break;
      }
      switch (p->rejected(attempt)) {
        case NewtonProblem::Retry::kSameIteration:
          break;
        case NewtonProblem::Retry::kNextIteration:
          next = true;
          break;
        case NewtonProblem::Retry::kStop:
          out.stop = NewtonStop::kStopped;
          return out;
      }
    }
  }
  out.stop = NewtonStop::kIterationLimit;
  return out;
}

}  // namespace corde
