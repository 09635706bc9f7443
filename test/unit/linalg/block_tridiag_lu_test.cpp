// The block LU of linalg/block_tridiag.h against a dense solve, on block-tridiagonal matrices with
// general (non-symmetric) diagonal blocks, and its refusal of a singular pivot block.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <random>

#include "corde_sim/linalg/block_tridiag.h"

namespace corde {
namespace {

// A diagonally dominant symmetric matrix of n blocks plus a skew part in each diagonal block.
BlockTridiag random_matrix(int n, std::mt19937* rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  BlockTridiag a;
  a.resize(n);
  for (int k = 0; k < n; ++k) {
    Mat6 s, w;
    for (int i = 0; i < 36; ++i) s(i) = u(*rng), w(i) = u(*rng);
    a.diag[k] = s * s.transpose() + 20.0 * Mat6::Identity() + (w - w.transpose());
    if (k + 1 < n)
      for (int i = 0; i < 36; ++i) a.lower[k](i) = u(*rng);
  }
  return a;
}

TEST(BlockTridiagLU, MatchesADenseSolve) {
  std::mt19937 rng(3);
  for (int n : {1, 2, 7, 40}) {
    const BlockTridiag a = random_matrix(n, &rng);
    EXPECT_GT((a.diag[0] - a.diag[0].transpose()).norm(), 1.0);  // not symmetric
    const Eigen::VectorXd b = Eigen::VectorXd::Random(a.size());
    const Eigen::VectorXd ref = a.dense().fullPivLu().solve(b);
    BlockTridiagLU lu;
    ASSERT_TRUE(lu.factor(a)) << n;
    Eigen::VectorXd x = b;
    lu.solve(&x);
    EXPECT_LT((x - ref).norm(), 1e-12 * ref.norm()) << n;
    EXPECT_LT((a.dense() * x - b).norm(), 1e-12 * b.norm()) << n;
  }
}

TEST(BlockTridiagLU, RefusesASingularPivot) {
  std::mt19937 rng(5);
  BlockTridiag a = random_matrix(5, &rng);
  BlockTridiagLU lu;
  EXPECT_TRUE(lu.factor(a));
  a.diag[0].row(2).setZero();  // the first pivot block is singular
  EXPECT_FALSE(lu.factor(a));
  a = random_matrix(5, &rng);
  a.diag[3](0, 0) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(lu.factor(a));
}

}  // namespace
}  // namespace corde
