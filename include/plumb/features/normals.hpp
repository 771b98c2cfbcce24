// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Surface normals by PCA over each point's neighbourhood (Liu et al. 2022, sec. 1.2 and 2.2).

#include <cstddef>
#include <limits>
#include <vector>

#include "plumb/core/point_cloud.hpp"
#include "plumb/core/types.hpp"
#include "plumb/search/kdtree.hpp"

namespace plumb {

/// @brief Neighbourhood and orientation of estimate_normals().
struct NormalSettings {
  /// Maximum neighbours per point (the point itself included), >= 3.
  std::size_t k = 20;
  /// Search radius [m]. 0 = plain k nearest; > 0 = hybrid: the k nearest that lie within `radius`
  /// (Open3D's KDTreeSearchParamHybrid). Points with fewer than 3 neighbours get a NaN normal.
  float radius = 0.0f;
  /// Normals are flipped to point toward this position (sensor origin by default) [m].
  Vector3f viewpoint = Vector3f::Zero();
  /// Flip toward `viewpoint`; false leaves the sign of the smallest eigenvector as computed.
  bool orient_to_viewpoint = true;
  /// Threads (0 = every core). Points are split into fixed chunks, so the normals are identical
  /// for any count (core/parallel.hpp).
  int threads = 1;
};

/// @brief Per-point normals and surface variation.
struct NormalResult {
  std::vector<Vector3f> normals;  ///< unit normal per input point; NaN where not estimable
  /// λ0 / (λ0 + λ1 + λ2) per point (PCL's surface variation); NaN likewise
  std::vector<float> curvature;
  /// points with a NaN normal (non-finite, < 3 neighbours, coincident or collinear)
  std::size_t num_invalid = 0;
};

/// @brief Normal of every point of `cloud`, by PCA of its neighbours in `tree`.
/// @param cloud query points (any size; non-finite points get NaN normals)
/// @param tree  kd-tree over the cloud whose neighbours are used (usually built on `cloud`)
/// @param tree_points the points `tree` was built from (indices returned by `tree` refer to them)
/// @note Per point: the neighbourhood's covariance (double, one pass about a neighbour) and its
///       smallest eigenvector by a closed-form 3x3 solver; no allocation per point. A neighbourhood
///       of < 3 points, or of coincident or collinear points, has no unique normal: NaN. The
///       hybrid search returns the k nearest points within `radius` (ties broken arbitrarily),
///       by a radius search while balls are small and by a k-nearest search where they are dense.
///       Deterministic for any settings.threads; O(n (k + log n)).
NormalResult estimate_normals(const std::vector<Vector3f>& cloud, const KdTree<3>& tree,
                              const std::vector<Vector3f>& tree_points,
                              const NormalSettings& settings = {});

/// @brief Convenience: builds a kd-tree on `cloud`, estimates normals and stores them in
///        `cloud.normals`. An empty cloud or one without finite points throws plumb::Error.
/// @return the number of points whose normal could not be estimated (stored as NaN)
std::size_t compute_normals(PointCloud& cloud, const NormalSettings& settings = {});

}  // namespace plumb
