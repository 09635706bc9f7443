// The shared Newton solver of linalg/newton.h on scalar problems: convergence from far with the
// line search, the full-step shortcut, and the two forms of Armijo's test on a merit that does
// not change.
#include "corde_sim/linalg/newton.h"

#include <gtest/gtest.h>

#include <cmath>

namespace corde {
namespace {

// Minimises phi(x) = x^4/4 + x^2/2 - x (residual 1 - x - x^3, Hessian 3x^2 + 1); `flat` makes
// the merit a constant instead (a search that can never decrease it).
class Scalar : public NewtonProblem {
 public:
  explicit Scalar(double x0, double flat = 0.0) : x_(x0), flat_(flat) {}
  double x() const { return x_; }
  int merits() const { return merits_; }

  double residual_norm() override { return std::abs(1.0 - x_ - x_ * x_ * x_); }
  Check check(double r) override { return r <= 1e-12 ? Check::kConverged : Check::kContinue; }
  bool direction(int attempt, double* slope) override {
    if (attempt > 0) return false;
    base_ = x_;
    const double r = 1.0 - x_ - x_ * x_ * x_;
    d_ = r / (3.0 * x_ * x_ + 1.0);
    *slope = -r * d_;
    return true;
  }
  Retry rejected(int) override {
    x_ = base_;
    return Retry::kStop;
  }
  void move(double alpha) override { x_ = base_ + alpha * d_; }
  double merit(double) override {
    ++merits_;
    return flat_ != 0.0 ? flat_ : phi(x_);
  }
  void base_merit(MeritAtIterate* m) override {
    m->phi = flat_ != 0.0 ? flat_ : phi(base_);
    m->noise = -1.0;  // no change counts as round-off: only Armijo's test accepts
  }
  double trial_residual() override { return residual_norm(); }
  void accept_trial() override {}

 private:
  static double phi(double x) { return 0.25 * x * x * x * x + 0.5 * x * x - x; }
  double x_, base_ = 0.0, d_ = 0.0, flat_;
  int merits_ = 0;
};

const double kRoot = 0.68232780382801932;  // of x^3 + x - 1

TEST(Newton, ConvergesFromFarWithTheLineSearch) {
  for (double cut : {0.0, 0.25}) {
    Scalar p(20.0);
    NewtonOptions o;
    o.line_search.full_step_cut = cut;
    const NewtonOutcome out = newton_solve(&p, o);
    EXPECT_EQ(out.stop, NewtonStop::kConverged) << cut;
    EXPECT_LE(out.iterations, 15) << cut;
    EXPECT_NEAR(p.x(), kRoot, 1e-12) << cut;
    // Near the root full steps cut the residual quadratically: taken without the merit.
    if (cut > 0.0)
      EXPECT_LT(p.merits(), out.iterations);
    else
      EXPECT_GE(p.merits(), out.iterations);
  }
}

TEST(Newton, StopsAtTheIterationLimit) {
  Scalar p(20.0);
  NewtonOptions o;
  o.max_iterations = 2;
  const NewtonOutcome out = newton_solve(&p, o);
  EXPECT_EQ(out.stop, NewtonStop::kIterationLimit);
  EXPECT_EQ(out.iterations, 2);
}

// A merit that never changes (1e12), with no allowance for round-off: tested on the change, no
// step passes Armijo and the search is rejected; tested as phi <= phi0 + c alpha slope, a step
// passes once that term is below the last digit of 1e12 (the implicit step's form).
TEST(Newton, ArmijoOnTheChangeRefusesAStepThatLowersNothing) {
  for (bool on_change : {true, false}) {
    Scalar p(20.0, 1e12);
    LineSearchOptions o;
    o.armijo_on_change = on_change;
    double slope = 0.0;
    ASSERT_TRUE(p.direction(0, &slope));
    MeritAtIterate m;
    const LineSearchResult r = line_search(&p, slope, p.residual_norm(), o, &m);
    EXPECT_EQ(r, on_change ? LineSearchResult::kRejected : LineSearchResult::kAccepted);
  }
}

}  // namespace
}  // namespace corde
