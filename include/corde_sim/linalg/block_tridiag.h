// Block-tridiagonal matrices with 6x6 blocks (the rod's Newton matrices: node i and segment i
// form block i, model/rod_system.h) and their O(n) factorisations: block Cholesky for the
// symmetric positive definite ones, block LU for those whose diagonal blocks are not symmetric.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "corde_sim/math/types.h"

namespace corde {

// Symmetric block-tridiagonal matrix of n blocks of 6: diag[k] = block (k, k) (both triangles
// stored), lower[k] = block (k + 1, k).
struct BlockTridiag {
  std::vector<Mat6> diag, lower;

  void resize(int blocks);
  void set_zero();
  int blocks() const { return static_cast<int>(diag.size()); }
  int size() const { return 6 * blocks(); }
  // Adds the 3x3 block m at (row unknown r, column unknown c), both multiples of 3 with
  // |r/6 - c/6| <= 1, and its transpose at (c, r) unless r == c.
  void add(int r, int c, const Mat3& m);
  // Fixes unknown i (a kinematic item or an unused slot): its row and column become e_i.
  void fix(int i);
  // y = A x (sizes size()).
  void multiply(const Eigen::VectorXd& x, Eigen::VectorXd* y) const;
  Eigen::MatrixXd dense() const;  // for tests and small problems
};

// O(n) block Cholesky of a symmetric positive definite BlockTridiag: A = L L^T with L block lower
// bidiagonal. Fixed-size 6x6 arithmetic; allocates only when the number of blocks grows.
class BlockTridiagSolver {
 public:
  // False when A is not positive definite: a pivot block fails Cholesky, or one of its pivots
  // (the squared diagonal of the factor, as LDL^T's D) is <= min_pivot.
  bool factor(const BlockTridiag& a, double min_pivot = 0.0);
  // Solves A x = b in place.
  void solve(Eigen::VectorXd* b) const;
  // The blocks of A^-1 on the diagonal and the first subdiagonal (diag[k] = (k, k), lower[k] =
  // (k + 1, k)) from the factorisation, by selected inversion (Takahashi's recurrences, from the
  // last block up): O(n) where the whole inverse is dense. Allocates only when the number of blocks
  // grows.
  void selected_inverse(std::vector<Mat6>* diag, std::vector<Mat6>* lower) const;

 private:
  std::vector<Mat6> l_inv_t_;  // L_kk^-T, the transposed inverse of each pivot block's factor
  std::vector<Mat6> l_lower_;  // L(k + 1, k)
  int blocks_ = 0;
};

// O(n) block LU of a BlockTridiag whose diagonal blocks need not be symmetric (the off-diagonal
// ones are still lower[k] below and lower[k]^T above): the Jacobian of forces that have no
// potential, such as dead torques on rotations. Block elimination without pivoting between blocks
// (full pivoting within each 6x6 pivot block), so meant for matrices near a definite one.
class BlockTridiagLU {
 public:
  // False when a pivot block is singular (or not finite).
  bool factor(const BlockTridiag& a);
  // Solves A x = b in place.
  void solve(Eigen::VectorXd* b) const;

 private:
  std::vector<Mat6> pivot_inv_;  // S_k^-1, S_k the Schur complements
  std::vector<Mat6> upper_;      // A_{k,k+1} = lower[k]^T
  std::vector<Mat6> gain_;       // A_{k+1,k} S_k^-1
  int blocks_ = 0;
};

}  // namespace corde
