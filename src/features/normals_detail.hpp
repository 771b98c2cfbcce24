// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// @brief The PCA steps of estimate_normals(), for plumb's own sources and tests (not installed).

#include <cstddef>
#include <vector>

#include <Eigen/Core>

#include "plumb/core/types.hpp"

namespace plumb::detail {

/// Covariance of the neighbours `idx[0..n)` about their mean, accumulated in double about the
/// first neighbour (a point of the neighbourhood, so the one-pass sums do not cancel).
Eigen::Matrix3d neighbourhood_covariance(const std::vector<Vector3f>& pts, const std::size_t* idx, std::size_t n);

/// Normal of a neighbourhood from its covariance: the eigenvector of the smallest eigenvalue, by
/// Eigen's closed-form 3x3 solver (trigonometric eigenvalues, eigenvectors from cross products of
/// the shifted rows, most separated eigenvalue first). Returns false when the neighbourhood is
/// degenerate: all points coincide, or they are collinear (two eigenvalues ~0: no unique normal).
bool normal_from_covariance(const Eigen::Matrix3d& cov, Vector3f& normal, float& curvature);

/// PCA of the neighbours `idx[0..n)`: unit normal (smallest eigenvector) and surface variation.
/// Returns false when the neighbourhood is degenerate (< 3 points, coincident or collinear).
bool pca_normal(const std::vector<Vector3f>& pts, const std::size_t* idx, std::size_t n, Vector3f& normal,
                float& curvature);

}  // namespace plumb::detail
