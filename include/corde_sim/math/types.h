// The project's fixed-size vector, matrix and quaternion types (Eigen, double precision).
// Quaternions follow docs/model.md ("Quaternions and directors"): coeffs() = (x, y, z, w), w the
// scalar part.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace corde {

using Vec3 = Eigen::Vector3d;
using Vec4 = Eigen::Vector4d;
using Vec6 = Eigen::Matrix<double, 6, 1>;
using Mat3 = Eigen::Matrix3d;
using Mat6 = Eigen::Matrix<double, 6, 6>;
using Quat = Eigen::Quaterniond;

}  // namespace corde
