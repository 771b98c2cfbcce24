// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// @brief The normal solver of sample_frame(), for plumb's own sources and tests (not installed).

#include <Eigen/Core>

#include "plumb/core/types.hpp"

namespace plumb::detail {

/// normal_from_covariance() (features/normals_detail.hpp) without trigonometry where the smallest
/// eigenvalue is well separated, which is the case on surfaces: the smallest root of the
/// characteristic polynomial by Newton's method from 0 (the cubic is increasing and concave up to
/// that root, so the iterates rise monotonically onto it), the other two from the remaining
/// quadratic, the eigenvector as the longest cross product of two rows of C - lambda0 I (as Eigen's
/// closed form does). When lambda1 - lambda0 < 1e-3 lambda2 (no clear normal, and every thin or
/// collinear set) it defers to normal_from_covariance(), which applies the degeneracy rule.
bool normal_from_covariance_fast(const Eigen::Matrix3d& cov, Vector3f& normal);

}  // namespace plumb::detail
