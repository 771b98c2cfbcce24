// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Vertical-plane key points (Liu et al. 2022, sec. 2.2, eq. 12): pre-segmentation by the
///        angle between u = n x i (or n x j) and z, repeated RANSAC for planes parallel to z, a minimum plane
///        size, and the full-resolution points of each plane.

#include <cstddef>
#include <cstdint>
#include <vector>

#include "plumb/core/point_cloud.hpp"
#include "plumb/core/status.hpp"
#include "plumb/segmentation/frame_sample.hpp"
#include "plumb/segmentation/ground.hpp"
#include "plumb/segmentation/plane_ransac.hpp"

namespace plumb {

/// @brief Settings of extract_vertical_planes(). Frame: sensor frame, z up.
struct VerticalPlaneSettings {
  double max_u_angle = 0.17453292519943295;  ///< Δθ1 of eq. 12 and the planes' tilt limit [rad] (10 deg)
  double distance_threshold = 0.05;          ///< τ: inlier distance to a plane [m], > 0
  /// A sample inlier's normal must be within this of the plane's normal [rad] (30 deg): keeps a
  /// plane from collecting the edge points of perpendicular walls.
  double max_normal_angle = 0.5235987755982988;
  std::size_t min_sample_inliers = 25;  ///< minimum plane size in sample points (>= 3)
  std::size_t max_planes = 8;           ///< planes extracted at most
  int max_iterations = 200;             ///< RANSAC cap per plane, >= 1
  double confidence = 0.99;             ///< RANSAC early stop per plane
  /// Full-resolution points are labelled only where the plane's sample inliers are: cells of this
  /// width along the plane's horizontal direction [m] (> 0), each occupied cell dilated by one
  /// cell plus a voxel; the height range of the inliers is widened by the same amount.
  double cell_size = 0.5;
  std::uint64_t seed = 42;  ///< seed of the first plane's RANSAC; plane k uses seed + k
};

/// @brief One vertical plane and where it was observed.
struct VerticalPlane {
  Plane plane;                      ///< normal horizontal within Δθ1, toward the sensor
  std::size_t num_sample_inliers = 0;  ///< sample points of the plane
  std::size_t num_points = 0;          ///< input points labelled with this plane
  double s_min = 0.0, s_max = 0.0;  ///< extent of the sample inliers along t = z x n [m]
  double z_min = 0.0, z_max = 0.0;  ///< height extent of the sample inliers [m]
  std::vector<std::uint8_t> cells;  ///< occupancy along t from s_min, cells of `cell_size`
  double rmse = 0.0;                ///< RMS distance of the sample inliers [m]
};

/// @brief Result of extract_vertical_planes().
struct VerticalPlanesResult {
  Status status = Status::kInsufficientData;  ///< kOk when at least one plane was found
  std::vector<VerticalPlane> planes;           ///< in extraction order (largest first, usually)
  /// Per input point: index into `planes`, or -1 (not on a vertical plane, or ground).
  std::vector<std::int32_t> plane_of_point;
  std::size_t num_points = 0;      ///< input points on some vertical plane
  std::size_t num_candidates = 0;  ///< sample points that passed the eq. 12 pre-segmentation
  int iterations = 0;              ///< RANSAC samples drawn, all planes
  double seconds = 0.0;            ///< wall time [s]
};

/// @brief Vertical planes of `cloud` from its sample (Liu et al. 2022, eq. 12).
///
/// Candidates: sample points with a normal whose eq. 12 angle is <= Δθ1 and that are not ground
/// sample inliers. Repeatedly: a RANSAC plane parallel to z (within Δθ1) with normal agreement,
/// hypotheses drawn as point + normal (PlaneSampling::kPointNormal);
/// accepted when it has >= min_sample_inliers, its inliers leave the candidate set; stops at the
/// first rejected plane or after max_planes. An input point belongs to the first plane it lies
/// within τ of, inside the plane's observed extent (occupied cells along the wall and the height
/// range, widened by a cell and a voxel); ground inliers are never vertical.
/// @param ground the ground found on the same frame, or null
/// @throws plumb::Error on invalid settings or a sample that does not match the cloud
VerticalPlanesResult extract_vertical_planes(const PointCloud& cloud, const FrameSample& sample,
                                             const GroundResult* ground,
                                             const VerticalPlaneSettings& settings = {});

}  // namespace plumb
