// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief PCD (Point Cloud Data, PCL's format) reading and writing: DATA ascii, binary and
///        binary_compressed (LZF).

#include <cstddef>
#include <string>

#include "plumb/core/point_cloud.hpp"

namespace plumb::io {

/// @brief How write_pcd() stores the point data.
enum class PcdEncoding {
  kAscii,             ///< one text line per point, shortest round-trip decimal form
  kBinary,            ///< interleaved little-endian records (array of structures)
  kBinaryCompressed,  ///< LZF-compressed structure-of-arrays buffer (PCL's binary_compressed)
};

/// @brief Options of read_pcd() / read_pcd_buffer().
struct PcdReadSettings {
  /// Drop points whose x, y or z is not finite (NaN / inf). Off by default: organized clouds
  /// (WIDTH x HEIGHT with NaN for missing returns) keep every point, in row-major order.
  bool drop_non_finite = false;
};

/// @brief Options of write_pcd().
struct PcdWriteSettings {
  PcdEncoding encoding = PcdEncoding::kBinary;  ///< DATA kind written
};

/// @brief Read a PCD file (VERSION .5 / 0.6 / 0.7; DATA ascii, binary or binary_compressed).
///
/// Fields mapped into the PointCloud: `x y z` (required), `normal_x normal_y normal_z` (all three,
/// else ignored), `intensity`, `ring`, `time` [s, relative to the frame stamp], `label`. Values of
/// any TYPE F (SIZE 4, 8), U or I (SIZE 1, 2, 4, 8) are converted; integer destinations (ring,
/// label) must receive integral in-range values. Every other field (rgb, rgba, curvature, `_`
/// padding, fields with COUNT > 1) is skipped. The cloud is flattened row-major (WIDTH x HEIGHT).
/// @param path file to read.
/// @param settings see PcdReadSettings.
/// @return the cloud; empty optional fields are absent from the file.
/// @throws plumb::Error naming the file and the header line or data byte offset for a missing,
///         truncated or malformed file. Declared sizes are checked against the data before any
///         allocation.
/// @note One read of the whole file, then direct parsing; linear in the file size.
PointCloud read_pcd(const std::string& path, const PcdReadSettings& settings = {});

/// @brief read_pcd() on a PCD image already in memory.
/// @param data, size the bytes of a whole PCD file.
/// @param name used in error messages in place of a path.
PointCloud read_pcd_buffer(const char* data, std::size_t size, const std::string& name,
                           const PcdReadSettings& settings = {});

/// @brief Write a cloud as PCD v0.7: fields x y z (F4) and every present optional field
///        (normal_x normal_y normal_z F4, intensity F4, ring U2, time F4, label I4).
///        WIDTH = number of points, HEIGHT = 1. Reading the file back gives the same cloud bit
///        for bit in every encoding.
/// @throws plumb::Error if the cloud is inconsistent or the file cannot be written.
void write_pcd(const std::string& path, const PointCloud& cloud, const PcdWriteSettings& settings = {});

/// @brief The bytes write_pcd() would write (for in-memory use and tests).
std::string write_pcd_buffer(const PointCloud& cloud, const PcdWriteSettings& settings = {});

}  // namespace plumb::io
