// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief 3D cloud -> planar LaserScan, with the semantics of ROS `pointcloud_to_laserscan`
///        (Liu et al. 2022, sec. 2.1): a height band, angular bins, the nearest range per bin.

#include <cmath>
#include <cstddef>
#include <limits>
#include <vector>

#include "plumb/core/error.hpp"
#include "plumb/core/point_cloud.hpp"
#include "plumb/core/status.hpp"
#include "plumb/core/types.hpp"
#include "plumb/core/laser_scan.hpp"

namespace plumb {

/// @brief Settings of cloud_to_scan(). Heights, ranges and angles are in the *target* frame, i.e.
///        after `T_target_sensor` is applied (x forward, y left, z up).
struct CloudToScanSettings {
  double min_height = -0.1;  ///< lowest z kept [m] (inclusive)
  double max_height = 0.1;   ///< highest z kept [m] (inclusive)
  double angle_min = -3.14159265358979323846;  ///< angle of the first bin [rad], in [-pi, pi]
  double angle_max = 3.14159265358979323846;   ///< points with a larger angle are dropped [rad]
  double angle_increment = 3.14159265358979323846 / 360.0;  ///< bin width [rad] (0.5 deg), > 0
  double range_min = 0.0;  ///< points with a horizontal range below this are dropped [m]
  double range_max = std::numeric_limits<double>::infinity();  ///< ... above this are dropped [m]
  /// Maps sensor-frame points into the frame the scan is made in (e.g. the robot base, whose z is
  /// up and whose origin is where the scan is centred). Identity: the scan is in the sensor frame.
  Eigen::Isometry3d T_target_sensor = Eigen::Isometry3d::Identity();
  double stamp = 0.0;  ///< copied into LaserScan::stamp [s]
};

/// @brief Result of cloud_to_scan().
struct CloudToScanResult {
  /// Regular scan: `ranges.size() = ceil((angle_max - angle_min) / angle_increment)`, beam i at
  /// `angle_min + i * angle_increment`; the nearest horizontal range of the bin's points, +inf for
  /// an empty bin. `range_min` / `range_max` are copied from the settings.
  LaserScan scan;
  /// The 2D point (x, y in the target frame) behind every non-empty bin, in beam order: the exact
  /// position of the nearest point, not the bin-centre reconstruction `scan.to_points()` gives.
  std::vector<Vector2d> points;
  std::vector<std::size_t> beam_indices;  ///< bin of each entry of `points`
  std::vector<std::size_t> source_indices;  ///< input-cloud index of each entry of `points`
  std::size_t num_in_band = 0;  ///< finite points inside the height band
  Status status = Status::kOk;  ///< kInsufficientData when no bin received a point
};

/// @brief Convert a 3D frame to a planar scan like ROS `pointcloud_to_laserscan`: transform each
///        finite point by `T_target_sensor`, keep it when `min_height <= z <= max_height`,
///        `range_min <= hypot(x, y) <= range_max` and `angle_min <= atan2(y, x) <= angle_max`, and
///        keep per bin `floor((angle - angle_min) / angle_increment)` the smallest range.
/// @param cloud the frame in the sensor frame; non-finite points are skipped
/// @param settings see CloudToScanSettings
/// @return the scan and its points; an empty or all-NaN frame gives an all-inf scan and
///         Status::kInsufficientData (never an exception)
/// @throws plumb::Error for settings that define no scan (increment <= 0 or not finite,
///         angle_max <= angle_min, min_height > max_height, range_min > range_max, NaN bounds)
/// @note ROS puts a point with angle exactly `angle_max` into bin `ranges.size()` (past the end);
///       here it goes into the last bin. O(n), one thread, deterministic.
inline CloudToScanResult cloud_to_scan(const PointCloud& cloud, const CloudToScanSettings& settings = {}) {
  const CloudToScanSettings& s = settings;
  PLUMB_CHECK(std::isfinite(s.angle_increment) && s.angle_increment > 0.0,
              "cloud_to_scan: angle_increment = " << s.angle_increment << " must be finite and > 0");
  PLUMB_CHECK(std::isfinite(s.angle_min) && std::isfinite(s.angle_max) && s.angle_max > s.angle_min,
              "cloud_to_scan: angle range [" << s.angle_min << ", " << s.angle_max << "] is empty");
  PLUMB_CHECK(!std::isnan(s.min_height) && !std::isnan(s.max_height) && s.min_height <= s.max_height,
              "cloud_to_scan: height band [" << s.min_height << ", " << s.max_height << "] is empty");
  PLUMB_CHECK(!std::isnan(s.range_min) && !std::isnan(s.range_max) && s.range_min <= s.range_max,
              "cloud_to_scan: range band [" << s.range_min << ", " << s.range_max << "] is empty");
  const double num_bins_d = std::ceil((s.angle_max - s.angle_min) / s.angle_increment);
  PLUMB_CHECK(num_bins_d <= 1e7, "cloud_to_scan: " << num_bins_d << " bins is too many (angle_increment "
                                                   << s.angle_increment << ")");
  const std::size_t num_bins = static_cast<std::size_t>(num_bins_d);

  CloudToScanResult out;
  LaserScan& scan = out.scan;
  scan.angle_min = s.angle_min;
  scan.angle_increment = s.angle_increment;
  scan.range_min = s.range_min;
  scan.range_max = s.range_max;
  scan.stamp = s.stamp;
  const float inf = std::numeric_limits<float>::infinity();
  scan.ranges.assign(num_bins, inf);
  std::vector<double> best(num_bins, std::numeric_limits<double>::infinity());
  std::vector<std::size_t> source(num_bins, 0);

  const Eigen::Matrix3d R = s.T_target_sensor.linear();
  const Eigen::Vector3d t = s.T_target_sensor.translation();
  const double range_min_sq = s.range_min * s.range_min;
  const double range_max_sq = s.range_max * s.range_max;
  for (std::size_t i = 0; i < cloud.points.size(); ++i) {
    const Vector3f& pf = cloud.points[i];
    if (!pf.allFinite()) continue;
    const Eigen::Vector3d p = R * pf.cast<double>() + t;
    if (p.z() < s.min_height || p.z() > s.max_height) continue;
    ++out.num_in_band;
    const double r_sq = p.x() * p.x() + p.y() * p.y();
    if (r_sq < range_min_sq || r_sq > range_max_sq) continue;
    const double angle = std::atan2(p.y(), p.x());
    if (angle < s.angle_min || angle > s.angle_max) continue;
    std::size_t bin = static_cast<std::size_t>((angle - s.angle_min) / s.angle_increment);
    if (bin >= num_bins) bin = num_bins - 1;
    if (r_sq < best[bin]) {
      best[bin] = r_sq;
      source[bin] = i;
    }
  }
  for (std::size_t b = 0; b < num_bins; ++b) {
    if (!std::isfinite(best[b])) continue;
    scan.ranges[b] = static_cast<float>(std::sqrt(best[b]));
    const Eigen::Vector3d p = R * cloud.points[source[b]].cast<double>() + t;
    out.points.emplace_back(p.x(), p.y());
    out.beam_indices.push_back(b);
    out.source_indices.push_back(source[b]);
  }
  out.status = out.points.empty() ? Status::kInsufficientData : Status::kOk;
  return out;
}

}  // namespace plumb
