// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Ground plane of a LiDAR frame (Liu et al. 2022, sec. 2.2): noise filter + normals on a
///        voxel sample, pre-segmentation by the normal's angle to z (eq. 8) and the projection
///        length l (eq. 9) around the expected ground distance l0, constrained RANSAC (eq. 10-11),
///        and the full-resolution ground points by distance to the plane.

#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

#include "plumb/core/point_cloud.hpp"
#include "plumb/core/status.hpp"
#include "plumb/segmentation/frame_sample.hpp"
#include "plumb/segmentation/plane_ransac.hpp"

namespace plumb {

/// @brief Settings of extract_ground(). The frame is the sensor frame: origin at the sensor, z up.
struct GroundSettings {
  /// l0: height of the sensor above the ground [m]. NaN = unknown: the ground is then the lowest
  /// large horizontal plane below the sensor (see extract_ground()).
  double sensor_height = std::numeric_limits<double>::quiet_NaN();
  double height_tolerance = 0.3;  ///< Δl: candidates have |l - l0| <= Δl [m], > 0
  double max_normal_angle = 0.2617993877991494;  ///< Δθ0: normal within this of +z [rad] (15 deg)
  double distance_threshold = 0.05;  ///< τ: inlier distance to the plane [m], > 0
  /// Unknown height only: a height (bin of width Δl/2, summed over ±Δl) is "large" when it holds at
  /// least this fraction of the most populated one, in [0, 1].
  double min_plane_fraction = 0.3;
  std::size_t min_sample_inliers = 30;  ///< fewer sample inliers -> no ground, >= 3
  int max_iterations = 1000;            ///< RANSAC cap, >= 1
  double confidence = 0.999;            ///< RANSAC early stop, see PlaneRansacSettings
  std::uint64_t seed = 42;              ///< RANSAC seed
  FrameSampleSettings sample;           ///< the voxel sample (ignored when a sample is passed in)
};

/// @brief Result of extract_ground().
struct GroundResult {
  /// kOk with a plane; kInsufficientData when there are too few (candidate) points or inliers;
  /// kDegenerate when no RANSAC sample satisfied the constraint.
  Status status = Status::kInsufficientData;
  Plane plane;  ///< n.p = D, n within Δθ0 of +z, oriented up (toward the sensor), so D = -height
  std::vector<std::size_t> inliers;         ///< input-cloud indices within τ of the plane, ascending
  std::vector<std::size_t> sample_inliers;  ///< sample indices within τ (and normal-consistent)
  std::size_t num_candidates = 0;  ///< sample points that passed the pre-segmentation
  double expected_height = std::numeric_limits<double>::quiet_NaN();  ///< l0 used [m]
  int iterations = 0;   ///< RANSAC samples drawn
  double rmse = 0.0;    ///< RMS distance of the sample inliers [m]
  double seconds = 0.0; ///< wall time (excluding the sample when one was passed in) [s]
};

/// @brief Ground plane from an existing sample of `cloud` (see sample_frame()).
///
/// Candidates are sample points whose normal is within Δθ0 of +z (eq. 8; normals point toward
/// the sensor, so a ceiling, whose normals point down, never qualifies), that lie below the sensor,
/// and whose projection length l (eq. 9) is within Δl of l0. With `sensor_height` unknown, l0 is
/// the largest l whose ±Δl window holds at least `min_plane_fraction` of the best window's points
/// (the lowest large horizontal plane, not the largest: indoors the ceiling or a table can be
/// larger in a frame than the visible floor). A RANSAC plane perpendicular to z (within Δθ0) is
/// fitted to the candidates; input points within τ of it are the ground.
/// @throws plumb::Error on invalid settings or when `sample` does not match `cloud`
GroundResult extract_ground(const PointCloud& cloud, const FrameSample& sample,
                            const GroundSettings& settings = {});

/// @brief Ground plane of `cloud`: sample_frame(cloud, settings.sample) with normals only below
///        the sensor (normal_max_z <= 0), then the overload above.
/// @return the ground; status kInsufficientData for an empty / all-NaN / tiny frame (no throw)
GroundResult extract_ground(const PointCloud& cloud, const GroundSettings& settings = {});

}  // namespace plumb
