// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief PLY (Stanford polygon format) point-cloud reading and writing.

#include <cstddef>
#include <string>

#include "plumb/core/point_cloud.hpp"

namespace plumb::io {

/// @brief How write_ply() stores the vertex data.
enum class PlyEncoding {
  kAscii,               ///< `format ascii 1.0`, shortest round-trip decimal form
  kBinaryLittleEndian,  ///< `format binary_little_endian 1.0`
};

/// @brief Options of write_ply().
struct PlyWriteSettings {
  PlyEncoding encoding = PlyEncoding::kBinaryLittleEndian;  ///< format written
};

/// @brief Read the vertices of a PLY file (ascii, binary_little_endian or binary_big_endian).
///
/// From `element vertex`: `x y z` (required), `nx ny nz` (all three, else ignored), `intensity`,
/// `ring`, `time` [s], `label`, each of any PLY scalar type (char..double, int8..float64);
/// integer destinations (ring, label) must receive integral in-range values. Other vertex
/// properties, list properties and other elements (faces, edges...) are skipped by their
/// declared types.
/// @throws plumb::Error naming the file and the header line or data byte offset (ascii: line)
///         for a missing, truncated or malformed file. Counts are checked against the data size
///         before any allocation.
PointCloud read_ply(const std::string& path);

/// @brief read_ply() on a PLY image already in memory; `name` stands for the path in messages.
PointCloud read_ply_buffer(const char* data, std::size_t size, const std::string& name);

/// @brief Write a cloud as a PLY with one `element vertex`: float x y z, and every present
///        optional field (float nx ny nz, float intensity, ushort ring, float time, int label).
///        Reading it back gives the same cloud bit for bit.
/// @throws plumb::Error if the cloud is inconsistent or the file cannot be written.
void write_ply(const std::string& path, const PointCloud& cloud, const PlyWriteSettings& settings = {});

/// @brief The bytes write_ply() would write.
std::string write_ply_buffer(const PointCloud& cloud, const PlyWriteSettings& settings = {});

}  // namespace plumb::io
