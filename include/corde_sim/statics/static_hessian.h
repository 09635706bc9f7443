// The Hessian of statics' problem (statics.h) as a sparse matrix: the stability of an equilibrium
// (its inertia) and buckling. A header of its own so that statics.h does not bring Eigen's sparse
// module into every file that includes it. Defined in statics.cpp, with solve_statics(), whose
// unknowns it shares.
#pragma once

#include <Eigen/SparseCore>

#include "corde_sim/statics/statics.h"

namespace corde {

// Symmetric Hessian of the total potential energy with respect to the free unknowns at the
// current state (kinematic nodes and segments as they are), in the scaled variables of statics.h:
// per node 3 displacements (2 in the plane if options.plane_normal is set), then per segment 3
// body rotations times the mean segment length (1 in the planar case), node i before segment i.
// Analytic (or, with options.finite_difference_hessian, fourth-order differences of the forces).
// Its lowest eigenvalue turns negative where a compressed rod buckles. Velocities are zeroed.
Eigen::SparseMatrix<double> static_hessian(Rod& rod, const Vec3& gravity, double t,
                                           const StaticOptions& options = StaticOptions());

}  // namespace corde
