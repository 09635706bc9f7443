// The sagging-cantilever reference of corde_charts (src/tools/chart_references.h): the planar
// extensible, shearable elastica under its own weight solved by shooting, checked against the
// linear formula at a small load and against the discrete rod's statics at the charts' load.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "chart_work_precision.h"

namespace corde {
namespace {

TEST(ChartsReference, SmallSagMatchesBeamFormula) {
  // q L^4/(8B) + q L^2/(2 kappa) (shear), L = 1; w = q L^3/B = 1e-3 keeps it linear (the large-
  // deflection terms are of relative order w^2).
  const double bend = 0.0785, stretch = 3142.0, kappa = 1047.0, q = 1e-3 * bend;
  const charts::SagElastica::Tip tip = charts::SagElastica{bend, stretch, kappa, q, 1.0}.solve();
  const double ref = q / (8.0 * bend) + q / (2.0 * kappa);
  EXPECT_NEAR(-tip.z / ref, 1.0, 1e-5);
  // The frames' droop angle at the tip, q L^3/(6B): shear tilts the centreline, not the frames.
  EXPECT_NEAR(tip.angle, q / (6.0 * bend), 1e-3 * q / (6.0 * bend));
}

// The rod's discrete equilibrium converges to the reference at second order (ghost clamp): a
// wrong reference would show as a floor.
TEST(ChartsReference, RodStaticsConvergeToItAtSecondOrder) {
  const charts::SagElastica::Tip ref = charts::SagScene::reference();
  double err[3];
  const int ns[3] = {10, 20, 40};
  for (int k = 0; k < 3; ++k)
    err[k] = charts::sag_point(charts::Method::kSplitRotation, ns[k], 1e-4, 1e-4, ref).error;
  const double p1 = std::log2(err[0] / err[1]), p2 = std::log2(err[1] / err[2]);
  std::printf("sag w = 5: tip error / L %.3e %.3e %.3e at N = 10, 20, 40; orders %.3f %.3f\n",
              err[0], err[1], err[2], p1, p2);
  EXPECT_NEAR(p1, 2.0, 0.15);
  EXPECT_NEAR(p2, 2.0, 0.15);
  EXPECT_LT(err[2], 5e-4);
}

}  // namespace
}  // namespace corde
