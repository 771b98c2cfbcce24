// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief KITTI Velodyne scans (`velodyne/NNNNNN.bin`): float32 records x y z intensity.

#include <cstddef>
#include <string>

#include "plumb/core/point_cloud.hpp"

namespace plumb::io {

/// @brief Read a KITTI velodyne .bin file: little-endian float32 x y z [m] and reflectance per point.
/// @return points and intensities (KITTI reflectance in [0, 1]).
/// @throws plumb::Error naming the file if it cannot be read or its size is not a multiple of 16.
PointCloud read_kitti_bin(const std::string& path);

/// @brief read_kitti_bin() on bytes in memory; `name` stands for the path in messages.
PointCloud read_kitti_bin_buffer(const char* data, std::size_t size, const std::string& name);

/// @brief Write x y z intensity float32 records; intensity 0 when the cloud has none.
///        Other fields (normals, rings, times, labels) are not stored by the format.
/// @throws plumb::Error if the cloud is inconsistent or the file cannot be written.
void write_kitti_bin(const std::string& path, const PointCloud& cloud);

}  // namespace plumb::io
