// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace plumb {

using Vector2f = Eigen::Vector2f;
using Vector3f = Eigen::Vector3f;
using Vector2d = Eigen::Vector2d;
using Vector3d = Eigen::Vector3d;
using Vector6d = Eigen::Matrix<double, 6, 1>;
using Matrix3d = Eigen::Matrix3d;
using Matrix6d = Eigen::Matrix<double, 6, 6>;

/// @brief pi, for every module (double precision).
constexpr double kPi = 3.14159265358979323846;

}  // namespace plumb
