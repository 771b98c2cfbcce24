// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Voxel-grid downsampling: one point per occupied voxel (Liu et al. 2022, sec. 1.2).

#include <cstddef>
#include <cstdint>
#include <vector>

#include "plumb/core/point_cloud.hpp"
#include "plumb/core/status.hpp"

namespace plumb {

/// @brief What a voxel keeps.
enum class VoxelMode {
  /// The real point nearest to the voxel's centroid, with all its fields copied unchanged
  /// (Liu et al. 2022, sec. 1.2: the output holds real measurements only). Ties go to the lowest
  /// source index.
  kNearestToCentroid,
  /// The centroid of the voxel's points (averaged in double). Normals are averaged and
  /// renormalized (if they cancel out, the nearest point's normal is used); intensities and times
  /// are averaged; rings and labels come from the point nearest the centroid.
  kCentroid,
};

/// @brief Settings of voxel_grid().
struct VoxelGridSettings {
  double leaf_size = 0.1;                          ///< voxel edge length [m]; finite and > 0
  VoxelMode mode = VoxelMode::kNearestToCentroid;  ///< see VoxelMode; default as in Liu et al. 2022, sec. 1.2
  std::size_t min_points_per_voxel = 1;            ///< voxels with fewer points are dropped; >= 1
};

/// @brief Result of voxel_grid().
struct VoxelGridResult {
  /// The downsampled cloud, one point per kept voxel, in ascending voxel-key order (see voxel_grid()).
  /// It has the same optional fields as the input.
  PointCloud cloud;
  /// kNearestToCentroid: `indices[i]` is the source index of `cloud.points[i]`.
  /// kCentroid: empty (the output points are averages, not source points).
  std::vector<std::size_t> indices;
  std::size_t num_voxels = 0;              ///< occupied voxels (>= 1 finite point), incl. sparse ones
  std::size_t num_sparse_voxels = 0;       ///< voxels dropped for having < min_points_per_voxel points
  std::size_t num_dropped_non_finite = 0;  ///< input points with a NaN or infinite coordinate
  /// kOk when the output has at least one point; kInsufficientData when it is empty (empty input,
  /// only non-finite points, or every voxel sparse). An empty frame is a normal event, not an error.
  Status status = Status::kInsufficientData;
};

/// @brief Downsample a cloud on a regular grid of cubic voxels, one output point per voxel.
///
/// The grid is anchored at the bounding-box minimum `min` of the cloud's finite points: a point p
/// falls into the voxel with integer coordinates `i_a = floor((p_a - min_a) / leaf_size)`, computed in
/// double (this is Open3D's `VoxelGrid::CreateFromPointCloudWithinBounds` convention with
/// `min_bound = min`; PCL's VoxelGrid anchors at the world origin, Open3D's VoxelDownSample at
/// `min - leaf/2`). The three coordinates are packed into one 64-bit key in mixed radix,
/// `key = i_x + n_x * (i_y + n_y * i_z)` with `n_a` the number of voxels spanned on axis a, so keys
/// never collide; the grid fits when `n_x * n_y * n_z <= 2^64` (e.g. 10 km x 10 km x 100 m at a
/// 1 mm leaf), otherwise plumb::Error names the extent and the leaf size.
///
/// @param cloud input; every present optional field must have one entry per point.
/// @param settings see VoxelGridSettings.
/// @return see VoxelGridResult. Non-finite points are dropped and counted.
/// @throws plumb::Error if leaf_size is not finite and > 0, min_points_per_voxel is 0, the cloud's
///         fields are inconsistent, the grid does not fit a 64-bit key, or the cloud has 2^32 or
///         more points.
/// @note Deterministic: output sorted by voxel key ascending, i.e. by (i_z, i_y, i_x)
///       lexicographically; the result depends only on the input and the settings.
///       O(n) time (keys + LSD radix sort + two linear passes), O(n) extra memory, no hashing, one
///       thread, no shared state (thread-safe for distinct outputs).
VoxelGridResult voxel_grid(const PointCloud& cloud, const VoxelGridSettings& settings = {});

namespace detail {

/// @brief How voxel coordinates are packed into 64-bit keys (see voxel_grid()).
struct VoxelKeyLayout {
  Vector3d origin = Vector3d::Zero();  ///< grid anchor = bounding-box minimum [m]
  double leaf_size = 0.0;              ///< [m]
  std::uint64_t n[3] = {0, 0, 0};      ///< voxels spanned per axis
  std::uint64_t stride_y = 0;          ///< n[0]
  std::uint64_t stride_z = 0;          ///< n[0] * n[1]
  int key_bits = 0;                    ///< bits needed by the largest key (0 for a single voxel)
};

/// @brief Layout for finite bounds min <= max; throws plumb::Error when it does not fit 64 bits.
VoxelKeyLayout make_voxel_key_layout(const Vector3d& min, const Vector3d& max, double leaf_size);

}  // namespace detail

}  // namespace plumb
