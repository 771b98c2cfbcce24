// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// @brief The steps of align_icp() (src/registration/icp.cpp), for plumb's own sources and tests
///        (not installed).

#include <cstddef>
#include <cstdint>
#include <vector>

#include "plumb/registration/icp.hpp"
#include "plumb/registration/overlap.hpp"

namespace plumb {

namespace detail {

/// One ICP pair: the source point mapped by the current estimate, its target neighbour and the
/// target normal (point-to-plane only).
struct IcpPair {
  Vector3d x;
  Vector3d q;
  Vector3d n;
  std::size_t i = 0;  ///< source index
  std::size_t j = 0;  ///< target index
  double r_sq = 0.0;  ///< squared residual of the metric
};

/// Source points per chunk of the parallel correspondence search (fixed: the result does not depend
/// on the thread count).
inline constexpr std::size_t kIcpGrain = 1024;

/// What each source point's last kd-tree query taught: its K nearest target points at the
/// position x_ref where it was made, and a radius r around x_ref that holds no other target point
/// (the K-th distance, or the query bound when fewer were within it). Reused across iterations and
/// rounds (it does not depend on d). ICP's updates shrink fast, so a point soon stays within a
/// few millimetres of x_ref, where the cache alone decides its nearest neighbour.
class IcpNnCache {
 public:
  /// Neighbours kept per point. Larger K answers more moves without a query but makes each
  /// query and each check dearer. Measured (bench/): 4 makes the BIM-corrected odometry's
  /// per-frame loop 14 % faster than 8 (its key points move little between iterations against a
  /// dense BIM cloud), and room_scan1's ICP, whose target holds every point twice, 5 % slower;
  /// 3 and 4 were the fastest for the odometry, 2 and 6 slower.
  static constexpr std::size_t kK = 4;

  struct Entry {
    Vector3f x_ref = Vector3f::Zero();  ///< where the point was at its last query
    float r = -1.0f;                    ///< no uncached target point lies closer to x_ref [m] (< 0: no query yet)
    std::uint32_t count = 0;            ///< cached neighbours, <= kK (fewer: no more within r)
    std::uint32_t idx[kK] = {};         ///< their target indices, nearest first at x_ref
  };

  explicit IcpNnCache(std::size_t num_source_points) : entries_(num_source_points) {}
  Entry& operator[](std::size_t i) { return entries_[i]; }

 private:
  std::vector<Entry> entries_;
};

/// Nearest-neighbour pairs of the source under T within distance d (Liu et al. 2022, sec. 1.3, ICP
/// steps (1)-(2)), through `cache` (cached_nearest), on s.threads threads. Returns the mean squared
/// residual of the metric.
double icp_pairs(const PointCloud& source, const PointCloud& target, const KdTree3f& tree, const Eigen::Isometry3d& T,
                 double d, const IcpSettings& s, std::vector<IcpPair>& pairs, IcpNnCache& cache);

/// overlap_ratio() of the source under T through the ICP's neighbour cache: the same result (see
/// cached_nearest), without a kd-tree query for most points.
OverlapResult icp_overlap(const PointCloud& source, const PointCloud& target, const KdTree3f& tree,
                          const Eigen::Isometry3d& T, double beta, IcpNnCache& cache, int threads = 1);

/// One update from the current pairs; false when the system cannot be solved.
bool icp_step(const std::vector<IcpPair>& pairs, const IcpSettings& s, Eigen::Isometry3d& delta);

}  // namespace detail
}  // namespace plumb
