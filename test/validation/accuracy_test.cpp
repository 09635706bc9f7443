// V8 core of corde_accuracy (src/tools/cantilever_step.h): the modal references and one tiny
// fine/coarse pair of the suddenly loaded cantilever (5 periods of mode 1, h = 0.9 critical).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "cantilever_step.h"

namespace corde {
namespace {

TEST(AccuracyV8, ModalSeriesStartsAtRestAndMatchesIndependentTimoshenkoRoots) {
  const Rod rod = v8::make_cantilever(v8::StepCase{});
  const Section& s = rod.section();
  const v8::ModalSeries eb(s.bend, s.mass_per_length, 1.0);
  const v8::ModalSeries timo(
      v8::Timoshenko{s.bend, s.kappa, s.mass_per_length, s.inertia_bend, 1.0}, 6);
  // The coefficients and omega_1 of the example rod from docs/validation_references.md (V8);
  // w(0) = 0 up to the truncation.
  EXPECT_NEAR(eb.coeff(0), 0.970688, 1e-6);
  EXPECT_NEAR(eb.coeff(3), 0.000821, 1e-6);
  EXPECT_NEAR(eb.omega(0), 1.75801, 1e-5);
  EXPECT_NEAR(eb(0.0), 0.0, 1e-5);
  EXPECT_NEAR(timo(0.0), 0.0, 1e-5);
  // Timoshenko roots from a separate shooting computation (scipy solve_ivp + brentq,
  // scripts/timoshenko_frequencies.py): omega_T/omega_EB - 1 for modes 1, 2, 4.
  EXPECT_NEAR(timo.omega(0) / eb.omega(0) - 1.0, -2.3222e-4, 2e-7);
  EXPECT_NEAR(timo.omega(1) / eb.omega(1) - 1.0, -1.6166e-3, 2e-7);
  EXPECT_NEAR(timo.omega(3) / eb.omega(3) - 1.0, -7.0565e-3, 2e-7);
}

TEST(AccuracyV8, FineSettingIsAccurateAndCoarseIsNot) {
  v8::StepCase fine;  // ghost clamp, N = 20
  fine.elements = 20;
  v8::StepCase coarse = fine;  // natural clamp, N = 10: frequencies about 25% high
  coarse.elements = 10;
  coarse.ghost_clamp = false;
  const v8::StepResult f = v8::run_step_case(fine), c = v8::run_step_case(coarse);
  std::printf("V8 quick: N=20 ghost error %.3e (Timoshenko %.3e), N=10 natural error %.3e\n",
              f.error_rms, f.error_rms_timoshenko, c.error_rms);
  ASSERT_TRUE(f.finite && c.finite);
  EXPECT_LT(f.error_rms, 0.05);  // measured 0.036
  EXPECT_GT(c.error_rms, 0.5);   // measured 0.94
  EXPECT_GT(c.error_rms, 10.0 * f.error_rms);
}

}  // namespace
}  // namespace corde
