// SPDX-License-Identifier: BSD-3-Clause
#pragma once

// Internals of plumb/loam/odometry.hpp that the tests use; the bodies are in src/loam/odometry.cpp.

#include <vector>

#include <Eigen/Geometry>

#include "plumb/core/robust_kernel.hpp"
#include "plumb/core/types.hpp"

namespace plumb {

namespace loam_detail {

using Factor = LoamCorrespondence;

/// The LOAM cost of `factors` at T under `kernel` (the sum of the kernel's loss over the residual
/// norms) and, when H is given, the Gauss-Newton system of it: H, g with the kernel's weights,
/// H_plain without them, and the plain sum of squared residuals in sum_sq.
double evaluate(const std::vector<Factor>& factors, const Eigen::Isometry3d& T, const RobustLoss& kernel,
                Matrix6d* H, Vector6d* g, Matrix6d* H_plain, double* sum_sq);

}  // namespace loam_detail

}  // namespace plumb
