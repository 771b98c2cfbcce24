// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// @brief Overlap ratio of a source cloud placed in a target (Liu et al. 2022, sec. 1.3).

#include <cstddef>

#include <Eigen/Geometry>

#include "plumb/core/point_cloud.hpp"
#include "plumb/search/kdtree.hpp"

namespace plumb {

/// @brief Result of overlap_ratio().
struct OverlapResult {
  /// alpha = num_inliers / num_valid, in [0, 1] (Liu et al. 2022, sec. 1.3, write alpha * 100 %)
  double overlap = 0.0;
  std::size_t num_inliers = 0;   ///< finite source points with a target point within beta
  std::size_t num_valid = 0;     ///< finite source points (N_p)
  double rmse = 0.0;             ///< RMS nearest distance over the inliers [m]
};

/// @brief Fraction of the (finite) source points whose nearest target point lies within `beta`
///        once the source is mapped by `T_target_source` (Liu et al. 2022, sec. 1.3; one kd-tree
///        query per point).
/// @param target_tree kd-tree over the target points
/// @param beta        inlier distance [m], finite and > 0
/// @throws plumb::Error for a bad beta or a non-finite transform
/// @note O(n log m); deterministic; thread-safe for concurrent calls on the same tree.
OverlapResult overlap_ratio(const PointCloud& source, const KdTree3f& target_tree,
                            const Eigen::Isometry3d& T_target_source, double beta);

}  // namespace plumb
