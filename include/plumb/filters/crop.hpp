// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Crop filters: axis-aligned (optionally posed) box and range (distance) band.

#include <cstddef>
#include <limits>
#include <optional>
#include <vector>

#include "plumb/core/point_cloud.hpp"
#include "plumb/core/status.hpp"
#include "plumb/core/types.hpp"

namespace plumb {

/// @brief Result of crop_box() and range_filter().
struct CropResult {
  PointCloud cloud;                    ///< kept points, every field copied, in source order
  std::vector<std::size_t> indices;    ///< `indices[i]` = source index of `cloud.points[i]`
  std::size_t num_dropped_non_finite = 0;  ///< input points with a NaN or infinite coordinate
  /// kOk when at least one point is kept; kInsufficientData when the output is empty (an empty
  /// frame or an empty crop is a normal event, not an error).
  Status status = Status::kInsufficientData;
};

/// @brief Settings of crop_box(). The defaults (an infinite box) keep every finite point.
struct CropBoxSettings {
  /// Box corner with the smallest coordinates, in the box frame [m]; may be -infinity.
  Vector3d min = Vector3d::Constant(-std::numeric_limits<double>::infinity());
  /// Box corner with the largest coordinates, in the box frame [m]; may be +infinity.
  Vector3d max = Vector3d::Constant(std::numeric_limits<double>::infinity());
  bool negative = false;  ///< false: keep points inside the box; true: keep the finite points outside
  /// Pose of the cloud in the box frame (maps cloud points into the box frame, where the box is
  /// axis-aligned). Absent: the box is axis-aligned in the cloud's own frame.
  std::optional<Eigen::Isometry3d> T_box_cloud;
};

/// @brief Keep the points inside (or, with `negative`, outside) a box; bounds are inclusive.
///
/// A point p is inside when `min <= q <= max` on every axis, with `q = T_box_cloud * p` (in double)
/// or `q = p` without a pose. Non-finite points are dropped in both modes and counted.
/// @throws plumb::Error if a bound is NaN, min > max on an axis, the pose is not finite, or the
///         cloud's fields are inconsistent.
/// @note O(n), deterministic (source order kept), thread-safe.
CropResult crop_box(const PointCloud& cloud, const CropBoxSettings& settings = {});

/// @brief Settings of range_filter(). The defaults keep every finite point.
struct RangeFilterSettings {
  double min_range = 0.0;                                       ///< smallest kept distance [m], >= 0
  double max_range = std::numeric_limits<double>::infinity();  ///< largest kept distance [m]
  Vector3d origin = Vector3d::Zero();  ///< the point distances are measured from (sensor) [m]
};

/// @brief Keep the points whose distance to `origin` lies in [min_range, max_range].
///
/// Squared distances are computed and compared in double; both bounds are inclusive. Non-finite
/// points are dropped and counted.
/// @throws plumb::Error if min_range < 0, max_range < min_range, a bound is NaN, the origin is not
///         finite, or the cloud's fields are inconsistent.
/// @note O(n), deterministic (source order kept), thread-safe.
CropResult range_filter(const PointCloud& cloud, const RangeFilterSettings& settings = {});

}  // namespace plumb
