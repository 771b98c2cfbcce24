// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// @brief Overlap ratio of a source cloud placed in a target (Liu et al. 2022, sec. 1.3).

#include <cmath>
#include <cstddef>

#include <Eigen/Geometry>

#include "plumb/core/error.hpp"
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
inline OverlapResult overlap_ratio(const PointCloud& source, const KdTree3f& target_tree,
                                   const Eigen::Isometry3d& T_target_source, double beta) {
  PLUMB_CHECK(std::isfinite(beta) && beta > 0.0, "overlap_ratio: beta = " << beta << " must be > 0");
  PLUMB_CHECK(T_target_source.matrix().allFinite(), "overlap_ratio: T_target_source is not finite");
  OverlapResult out;
  const Eigen::Matrix3f R = T_target_source.linear().cast<float>();
  const Eigen::Vector3f t = T_target_source.translation().cast<float>();
  const float beta_sq = static_cast<float>(beta * beta);
  double sum_sq = 0.0;
  for (const Vector3f& p : source.points) {
    if (!p.allFinite()) continue;
    ++out.num_valid;
    const auto nn = target_tree.nearest(R * p + t, beta_sq);
    if (nn && nn->dist_sq <= beta_sq) {
      ++out.num_inliers;
      sum_sq += nn->dist_sq;
    }
  }
  if (out.num_valid > 0) out.overlap = static_cast<double>(out.num_inliers) / static_cast<double>(out.num_valid);
  if (out.num_inliers > 0) out.rmse = std::sqrt(sum_sq / static_cast<double>(out.num_inliers));
  return out;
}

}  // namespace plumb
