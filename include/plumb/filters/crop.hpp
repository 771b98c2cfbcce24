// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Crop filters: axis-aligned (optionally posed) box and range (distance) band.

#include <cmath>
#include <cstddef>
#include <limits>
#include <optional>
#include <vector>

#include "plumb/core/error.hpp"
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
inline CropResult crop_box(const PointCloud& cloud, const CropBoxSettings& settings = {});

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
inline CropResult range_filter(const PointCloud& cloud, const RangeFilterSettings& settings = {});

namespace detail {

/// Keep the finite points for which keep(p) is true; copies every field.
template <typename Keep>
CropResult filter_finite_points(const PointCloud& cloud, Keep keep) {
  CropResult result;
  const std::vector<Vector3f>& pts = cloud.points;
  result.indices.reserve(pts.size());
  for (std::size_t i = 0; i < pts.size(); ++i) {
    if (!pts[i].allFinite()) {
      ++result.num_dropped_non_finite;
      continue;
    }
    if (keep(pts[i])) result.indices.push_back(i);
  }
  const std::vector<std::size_t>& idx = result.indices;
  PointCloud& out = result.cloud;
  auto copy = [&](const auto& src, auto& dst) {
    if (src.empty()) return;
    dst.resize(idx.size());
    for (std::size_t k = 0; k < idx.size(); ++k) dst[k] = src[idx[k]];
  };
  copy(cloud.points, out.points);
  copy(cloud.normals, out.normals);
  copy(cloud.intensities, out.intensities);
  copy(cloud.rings, out.rings);
  copy(cloud.times, out.times);
  copy(cloud.labels, out.labels);
  result.status = out.empty() ? Status::kInsufficientData : Status::kOk;
  return result;
}

}  // namespace detail

inline CropResult crop_box(const PointCloud& cloud, const CropBoxSettings& settings) {
  const Vector3d& lo = settings.min;
  const Vector3d& hi = settings.max;
  PLUMB_CHECK(!lo.hasNaN() && !hi.hasNaN(), "crop_box: box bounds must not be NaN (min = "
                                                << lo.transpose() << ", max = " << hi.transpose()
                                                << ")");
  PLUMB_CHECK((lo.array() <= hi.array()).all(), "crop_box: min must be <= max on every axis (min = "
                                                    << lo.transpose() << ", max = "
                                                    << hi.transpose() << ")");
  cloud.check_consistent("crop_box");
  const bool negative = settings.negative;
  if (!settings.T_box_cloud) {
    return detail::filter_finite_points(cloud, [&](const Vector3f& p) {
      const Vector3d q = p.cast<double>();
      const bool inside = (q.array() >= lo.array()).all() && (q.array() <= hi.array()).all();
      return inside != negative;
    });
  }
  const Eigen::Isometry3d& T = *settings.T_box_cloud;
  PLUMB_CHECK(T.matrix().allFinite(), "crop_box: T_box_cloud must be finite");
  const Matrix3d R = T.linear();
  const Vector3d t = T.translation();
  return detail::filter_finite_points(cloud, [&](const Vector3f& p) {
    const Vector3d q = R * p.cast<double>() + t;
    const bool inside = (q.array() >= lo.array()).all() && (q.array() <= hi.array()).all();
    return inside != negative;
  });
}

inline CropResult range_filter(const PointCloud& cloud, const RangeFilterSettings& settings) {
  const double r_min = settings.min_range;
  const double r_max = settings.max_range;
  PLUMB_CHECK(!std::isnan(r_min) && !std::isnan(r_max) && r_min >= 0.0 && r_max >= r_min,
              "range_filter: need 0 <= min_range <= max_range, got min_range = "
                  << r_min << " m, max_range = " << r_max << " m");
  PLUMB_CHECK(settings.origin.allFinite(),
              "range_filter: origin must be finite, got " << settings.origin.transpose());
  cloud.check_consistent("range_filter");
  const double r_min_sq = r_min * r_min;
  const double r_max_sq = r_max * r_max;
  const Vector3d o = settings.origin;
  return detail::filter_finite_points(cloud, [&](const Vector3f& p) {
    const double d_sq = (p.cast<double>() - o).squaredNorm();
    return d_sq >= r_min_sq && d_sq <= r_max_sq;
  });
}

}  // namespace plumb
