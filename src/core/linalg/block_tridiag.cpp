#include "corde_sim/linalg/block_tridiag.h"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>

namespace corde {

// ---------------------------------------------------------------------------------------------
// BlockTridiag

void BlockTridiag::resize(int blocks) {
  diag.resize(blocks);
  lower.resize(std::max(0, blocks - 1));
}

void BlockTridiag::set_zero() {
  for (Mat6& m : diag) m.setZero();
  for (Mat6& m : lower) m.setZero();
}

void BlockTridiag::add(int r, int c, const Mat3& m) {
  const int br = r / 6, bc = c / 6, ro = r % 6, co = c % 6;
  if (br == bc) {
    diag[br].block<3, 3>(ro, co) += m;
    if (r != c) diag[br].block<3, 3>(co, ro) += m.transpose();
  } else if (br == bc + 1) {
    lower[bc].block<3, 3>(ro, co) += m;
  } else {
    lower[br].block<3, 3>(co, ro) += m.transpose();
  }
}

void BlockTridiag::fix(int i) {
  const int k = i / 6, o = i % 6;
  diag[k].row(o).setZero();
  diag[k].col(o).setZero();
  diag[k](o, o) = 1.0;
  if (k < static_cast<int>(lower.size())) lower[k].col(o).setZero();
  if (k > 0) lower[k - 1].row(o).setZero();
}

void BlockTridiag::multiply(const Eigen::VectorXd& x, Eigen::VectorXd* y) const {
  y->resize(size());
  const int n = blocks();
  for (int k = 0; k < n; ++k) {
    Vec6 acc = diag[k] * x.segment<6>(6 * k);
    if (k > 0) acc += lower[k - 1] * x.segment<6>(6 * k - 6);
    if (k + 1 < n) acc += lower[k].transpose() * x.segment<6>(6 * k + 6);
    y->segment<6>(6 * k) = acc;
  }
}

Eigen::MatrixXd BlockTridiag::dense() const {
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(size(), size());
  for (int k = 0; k < blocks(); ++k) {
    a.block<6, 6>(6 * k, 6 * k) = diag[k];
    if (k + 1 < blocks()) {
      a.block<6, 6>(6 * k + 6, 6 * k) = lower[k];
      a.block<6, 6>(6 * k, 6 * k + 6) = lower[k].transpose();
    }
  }
  return a;
}

// ---------------------------------------------------------------------------------------------
// BlockTridiagSolver: S_0 = A_00, S_k = A_kk - C_{k-1} C_{k-1}^T with L_kk = chol(S_k) and
// C_k = A_{k+1,k} L_kk^-T.

namespace {

// Cholesky of the 6x6 s (lower triangle read) into l (lower triangle written; the strict upper
// triangle gets finite values of no meaning) and the inverse of its diagonal; false when a pivot
// l_jj^2 is <= min_pivot (or NaN). Left-looking, a whole column at a time: column operations
// vectorise where element-wise loops would not.
bool cholesky6(const Mat6& s, double min_pivot, Mat6* l, Vec6* inv_diag) {
  for (int j = 0; j < 6; ++j) {
    Vec6 col = s.col(j);
    for (int k = 0; k < j; ++k) col -= (*l)(j, k) * l->col(k);
    if (!(col(j) > min_pivot)) return false;
    const double inv = 1.0 / std::sqrt(col(j));
    (*inv_diag)(j) = inv;
    l->col(j) = inv * col;
  }
  return true;
}

// x = b L^-T for the factor l of cholesky6 (column j of x solves x L^T = b for that column by
// substitution), accumulated a whole column at a time for the same reason.
void right_solve_lt(const Mat6& l, const Vec6& inv_diag, const Mat6& b, Mat6* x) {
  for (int j = 0; j < 6; ++j) {
    Vec6 col = b.col(j);
    for (int m = 0; m < j; ++m) col -= l(j, m) * x->col(m);
    x->col(j) = inv_diag(j) * col;
  }
}

}  // namespace

bool BlockTridiagSolver::factor(const BlockTridiag& a, double min_pivot) {
  const int n = a.blocks();
  if (static_cast<int>(l_inv_t_.size()) < n) {
    l_inv_t_.resize(n);
    l_lower_.resize(n);
  }
  Mat6 s, l;
  Vec6 inv;
  for (int k = 0; k < n; ++k) {
    s = a.diag[k];
    if (k > 0) {
      // S -= C C^T on the lower triangle only (all cholesky6 reads), in column pairs: a third
      // fewer products than the full block.
      const Mat6& c = l_lower_[k - 1];
      s.block<6, 2>(0, 0).noalias() -= c * c.topRows<2>().transpose();
      s.block<4, 2>(2, 2).noalias() -= c.middleRows<4>(2) * c.middleRows<2>(2).transpose();
      s.block<2, 2>(4, 4).noalias() -= c.bottomRows<2>() * c.bottomRows<2>().transpose();
    }
    if (!cholesky6(s, min_pivot, &l, &inv)) return false;
    // Keeps L^-T (column j of it is row j of L^-1) so that the solves multiply by it, which
    // vectorises, instead of substituting element by element; and C = A_{k+1,k} L^-T.
    right_solve_lt(l, inv, Mat6::Identity(), &l_inv_t_[k]);
    if (k + 1 < n) right_solve_lt(l, inv, a.lower[k], &l_lower_[k]);
  }
  blocks_ = n;
  return true;
}

void BlockTridiagSolver::solve(Eigen::VectorXd* b) const {
  const int n = blocks_;
  Vec6 y;
  for (int k = 0; k < n; ++k) {
    y = b->segment<6>(6 * k);
    if (k > 0) y.noalias() -= l_lower_[k - 1] * b->segment<6>(6 * k - 6);
    b->segment<6>(6 * k).noalias() = l_inv_t_[k].transpose() * y;
  }
  for (int k = n - 1; k >= 0; --k) {
    y = b->segment<6>(6 * k);
    if (k + 1 < n) y.noalias() -= l_lower_[k].transpose() * b->segment<6>(6 * k + 6);
    b->segment<6>(6 * k).noalias() = l_inv_t_[k] * y;
  }
}

// With A = L L^T, Sigma = A^-1 satisfies Sigma L = L^-T, whose blocks below the diagonal are zero:
// Sigma_{k+1,k} = -Sigma_{k+1,k+1} G_k and Sigma_kk = L_kk^-T L_kk^-1 + G_k^T Sigma_{k+1,k+1} G_k,
// G_k = L_{k+1,k} L_kk^-1.
void BlockTridiagSolver::selected_inverse(std::vector<Mat6>* diag, std::vector<Mat6>* lower) const {
  const int n = blocks_;
  diag->resize(n);
  lower->resize(std::max(0, n - 1));
  if (n == 0) return;
  (*diag)[n - 1].noalias() = l_inv_t_[n - 1] * l_inv_t_[n - 1].transpose();
  Mat6 g, sg;
  for (int k = n - 2; k >= 0; --k) {
    g.noalias() = l_lower_[k] * l_inv_t_[k].transpose();
    sg.noalias() = (*diag)[k + 1] * g;
    (*lower)[k] = -sg;
    (*diag)[k].noalias() = l_inv_t_[k] * l_inv_t_[k].transpose();
    (*diag)[k].noalias() += g.transpose() * sg;
  }
}

// ---------------------------------------------------------------------------------------------
// BlockTridiagLU: S_0 = A_00, S_{k+1} = A_{k+1,k+1} - A_{k+1,k} S_k^-1 A_{k,k+1}.

bool BlockTridiagLU::factor(const BlockTridiag& a) {
  const int n = a.blocks();
  pivot_inv_.resize(n);
  upper_.resize(std::max(0, n - 1));
  gain_.resize(std::max(0, n - 1));
  Mat6 s;
  for (int k = 0; k < n; ++k) {
    s = a.diag[k];
    if (k > 0) s.noalias() -= gain_[k - 1] * upper_[k - 1];
    if (!s.allFinite()) return false;
    const Eigen::FullPivLU<Mat6> lu(s);
    if (!lu.isInvertible()) return false;
    pivot_inv_[k] = lu.inverse();
    if (k + 1 < n) {
      upper_[k] = a.lower[k].transpose();
      gain_[k].noalias() = a.lower[k] * pivot_inv_[k];
    }
  }
  blocks_ = n;
  return true;
}

void BlockTridiagLU::solve(Eigen::VectorXd* b) const {
  const int n = blocks_;
  for (int k = 1; k < n; ++k) b->segment<6>(6 * k) -= gain_[k - 1] * b->segment<6>(6 * k - 6);
  Vec6 y;
  for (int k = n - 1; k >= 0; --k) {
    y = b->segment<6>(6 * k);
    if (k + 1 < n) y.noalias() -= upper_[k] * b->segment<6>(6 * k + 6);
    b->segment<6>(6 * k).noalias() = pivot_inv_[k] * y;
  }
}

}  // namespace corde
