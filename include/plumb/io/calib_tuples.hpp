// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Reading and writing calibration tuple files in the format of Censi's odometry/laser
///        calibration tool: JSON lines, one object per tuple (several objects on one line are accepted),
///        `{ "T": 0.79, "phi_l": 0.14, "phi_r": -0.137, "sm": [ 0.0011, -0.0005, -0.0275 ] }`
///        with the interval T [s], the mean left/right wheel angular velocities [rad/s] and the
///        scan-matcher laser motion (x [m], y [m], θ [rad]).
///
/// The reader skips blank lines and lines starting with `#`, accepts LF and CRLF, ignores other
/// keys whose values are numbers, strings, booleans, null or arrays of those, and throws
/// plumb::Error naming the file and the 1-based line for anything else: a line that is not one
/// JSON object, a missing or repeated key, a non-finite number, `sm` without exactly 3 numbers,
/// T <= 0, a file that cannot be opened or holds no tuple.

#include <string>
#include <vector>

#include "plumb/core/sensor_data.hpp"

namespace plumb::io {

/// @brief Read a tuple file (see the file comment).
/// @throws plumb::Error (file and line in the message) on unreadable, empty or malformed input.
std::vector<CalibrationTuple> read_calib_tuples(const std::string& path);

/// @brief Parse tuple-file text (as read_calib_tuples does); `name` is used in error messages.
std::vector<CalibrationTuple> parse_calib_tuples(const std::string& text, const std::string& name);

/// @brief Write a tuple file that read_calib_tuples() and Censi's solver read; doubles are written
///        in their shortest round-trip form, so write/read is lossless.
/// @throws plumb::Error if the file cannot be written.
void write_calib_tuples(const std::vector<CalibrationTuple>& tuples, const std::string& path);

}  // namespace plumb::io
