// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Reading and writing trajectories: TUM (`stamp tx ty tz qx qy qz qw`) and KITTI (12 floats
///        per line, row-major 3x4 `[R|t]`, optionally with a times file of one stamp per line).
///
/// Readers skip blank lines and lines starting with `#`, accept LF and CRLF line endings, and throw
/// plumb::Error naming the file and the 1-based line for anything they cannot use: a wrong number
/// of fields, a field that is not a finite number, a quaternion or rotation too far from a valid
/// rotation, a coordinate beyond TrajectoryReadSettings::max_abs_coordinate, a stamp that does not
/// increase over the previous line's, an empty file, a path that is a directory or cannot be
/// opened. Writers emit every double in its shortest
/// form that reads back bit-identically (std::to_chars), so a write/read round trip is lossless for
/// stamps, translations and KITTI matrices (a TUM quaternion round-trips to ~1e-16).

#include <string>
#include <vector>

#include "plumb/core/trajectory.hpp"

namespace plumb::io {

/// @brief How strictly the trajectory readers treat rotations that are not exactly valid.
struct TrajectoryReadSettings {
  /// TUM: a quaternion with | |q| - 1 | up to this is normalized; beyond it (or |q| = 0) the line
  /// is an error. The default accepts files printed with 4 decimals.
  double max_quaternion_norm_error = 1e-3;
  /// KITTI: a rotation block with max |R^T R - I| (entry-wise) up to this is replaced by the nearest
  /// rotation (SVD); beyond it, or with det(R) <= 0, the line is an error.
  double max_rotation_error = 1e-3;
  /// KITTI: when false, rotations within max_rotation_error are kept as printed (not projected
  /// onto SO(3)); this is what evo does, and what reproduces its numbers bit for bit.
  bool orthonormalize = true;
  /// Stamps (TUM, times files) must strictly increase from line to line: a file out of order (or
  /// with a repeated stamp) is an error naming the line, since association by stamp and path
  /// lengths would silently be wrong. False accepts any order.
  bool require_increasing_stamps = true;
  /// Largest accepted |x|, |y|, |z| of a position [m]: 1e9 m is far beyond any real map (UTM and
  /// ECEF coordinates stay below 1e7 m), while squares of such values still fit a double, so
  /// the error statistics cannot overflow to inf.
  double max_abs_coordinate = 1e9;
};

/// @brief Read a TUM trajectory file (`stamp tx ty tz qx qy qz qw` per line, SI units).
/// @throws plumb::Error (file and line in the message) on unreadable, empty or malformed input.
Trajectory read_tum(const std::string& path, const TrajectoryReadSettings& settings = {});

/// @brief read_tum() on text held in memory; `name` stands for the path in messages.
Trajectory parse_tum(const std::string& text, const std::string& name, const TrajectoryReadSettings& settings = {});

/// @brief Write a TUM trajectory file. Needs stamps (one per pose).
/// @throws plumb::Error if the trajectory has no stamps or the file cannot be written.
void write_tum(const Trajectory& trajectory, const std::string& path);

/// @brief Read a KITTI pose file; with `times_path` non-empty, also its times file (one stamp per
///        line, as many as poses), else the trajectory has no stamps.
/// @throws plumb::Error (file and line in the message) on unreadable, empty or malformed input,
///         or when the times file has a different number of entries than the pose file.
Trajectory read_kitti(const std::string& path, const std::string& times_path = "",
                      const TrajectoryReadSettings& settings = {});

/// @brief read_kitti() of a pose file held in memory (no stamps); `name` stands for the path in
///        messages.
Trajectory parse_kitti(const std::string& text, const std::string& name, const TrajectoryReadSettings& settings = {});

/// @brief Write a KITTI pose file; with `times_path` non-empty also the stamps (which must exist).
/// @throws plumb::Error if a file cannot be written or stamps are asked for but missing.
void write_kitti(const Trajectory& trajectory, const std::string& path,
                 const std::string& times_path = "");

/// @brief Read a times file: one finite number per non-comment line, strictly increasing unless
///        `settings.require_increasing_stamps` is false.
/// @throws plumb::Error on unreadable, empty or malformed input.
std::vector<double> read_times(const std::string& path, const TrajectoryReadSettings& settings = {});

/// @brief read_times() on text held in memory; `name` stands for the path in messages.
std::vector<double> parse_times(const std::string& text, const std::string& name,
                                const TrajectoryReadSettings& settings = {});

}  // namespace plumb::io
