// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Read or write a point cloud choosing the format by file extension (.pcd, .ply, .bin).

#include <string>

#include "plumb/core/point_cloud.hpp"

namespace plumb::io {

/// @brief read_pcd(), read_ply() or read_kitti_bin() by the (case-insensitive) extension of `path`.
/// @throws plumb::Error for an unknown extension or whatever the format reader throws.
PointCloud read_cloud(const std::string& path);

/// @brief write_pcd() (binary_compressed), write_ply() (binary) or write_kitti_bin() by extension.
/// @throws plumb::Error for an unknown extension or whatever the format writer throws.
void write_cloud(const std::string& path, const PointCloud& cloud);

}  // namespace plumb::io
