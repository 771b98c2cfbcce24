// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Road (ground) returns of one multi-ring frame: LeGO-LOAM's test on vertically adjacent
///        pixels of the range image, completed by a plane fitted to what that test found.
///
/// The pair test marks a return only when the return above it in the same image column continues
/// the road. It misses road returns whose upper neighbour is lost (out of range, taken by a nearer
/// point) or off the road. Few in number, they are a large share of what is left as structure in
/// the open (on the simulated duplex site, over half of a frame's "structure" returns), and as
/// ring arcs that barely move with the sensor they hold scan-matched frames back.

#include <cstddef>
#include <vector>

#include <Eigen/Core>

#include "plumb/core/point_cloud.hpp"
#include "plumb/loam/range_image.hpp"

namespace plumb {

/// @brief Settings of classify_ground().
struct RingGroundSettings {
  /// Two vertically adjacent returns below the horizon whose joining segment is flatter than this
  /// are ground (LeGO-LOAM's test) [deg], in [0, 90).
  double max_slope_deg = 10.0;
  /// Every return below the sensor within this distance of the plane fitted to the pair test's
  /// ground is ground too [m]; 0 = the pair test only.
  double plane_tolerance = 0.15;
  /// The plane needs at least this many pair-test returns (fewer: the pair test only).
  std::size_t min_plane_points = 30;
};

/// @brief What classify_ground() found.
struct RingGroundResult {
  std::vector<char> ground;         ///< per point of the cloud: 1 = ground
  std::size_t num_ground = 0;       ///< points marked
  std::size_t num_from_plane = 0;   ///< ... of which by the plane, not the pair test
  bool plane_used = false;          ///< a plane was fitted and used
  Eigen::Vector3d plane = Eigen::Vector3d::Zero();  ///< z = a x + b y + c in the levelled frame (a, b, c)
};

/// @brief Mark the road returns of a frame.
/// @param cloud the frame in the LiDAR frame (origin at the optical centre)
/// @param image its range image (build_range_image() of the same cloud)
/// @param R_level rotation of the LiDAR frame into a z-up frame (the sensor's roll and pitch; any yaw)
/// @param settings see RingGroundSettings
/// @return per-point flags and counts. The plane is z = a x + b y + c fitted by least squares to
///         the pair test's returns, refitted twice on those within plane_tolerance of the last fit
///         (the pair test also joins a road return to a low return on a wall or step above it); it
///         is not used when steeper than max_slope_deg or not below the sensor.
/// @throws plumb::Error when the image does not belong to the cloud or the settings are out of range
/// @note O(n); deterministic; no shared state.
RingGroundResult classify_ground(const PointCloud& cloud, const RangeImage& image,
                                 const Eigen::Matrix3d& R_level, const RingGroundSettings& settings = {});

}  // namespace plumb
