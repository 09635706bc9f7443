// A BlockTridiag as an Eigen sparse matrix (both triangles), for tests, benchmarks and callers
// that hand the matrix on; kept apart so that the sparse module is included only where needed.
#pragma once

#include <Eigen/SparseCore>
#include <vector>

#include "corde_sim/linalg/block_tridiag.h"

namespace corde {

inline Eigen::SparseMatrix<double> to_sparse(const BlockTridiag& a) {
  std::vector<Eigen::Triplet<double>> trip;
  trip.reserve(static_cast<size_t>(a.blocks()) * 36 * 3);
  for (int k = 0; k < a.blocks(); ++k)
    for (int i = 0; i < 6; ++i)
      for (int j = 0; j < 6; ++j) {
        if (a.diag[k](i, j) != 0.0) trip.emplace_back(6 * k + i, 6 * k + j, a.diag[k](i, j));
        if (k + 1 < a.blocks() && a.lower[k](i, j) != 0.0) {
          trip.emplace_back(6 * k + 6 + i, 6 * k + j, a.lower[k](i, j));
          trip.emplace_back(6 * k + j, 6 * k + 6 + i, a.lower[k](i, j));
        }
      }
  Eigen::SparseMatrix<double> m(a.size(), a.size());
  m.setFromTriplets(trip.begin(), trip.end());
  return m;
}

}  // namespace corde
