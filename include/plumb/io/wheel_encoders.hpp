// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Wheel encoder logs as CSV: one reading per line, `stamp,left,right`, with cumulative
///        wheel angles in radians (forward positive) or, with ticks_per_revolution set, cumulative
///        encoder tick counts. This is the `wheels.csv` of a frame dump and what
///        `plumb calibrate --log LOG --wheels WHEELS.csv` reads.
///
/// The reader accepts commas, semicolons, tabs or spaces between fields, LF or CRLF, blank lines,
/// `#` comments, and one header line (the first non-comment line when it does not start with a
/// number, e.g. `stamp,left,right`). It throws plumb::Error naming the file and 1-based line for
/// anything else: fewer than 3 fields, a field that is not a finite number, stamps that do not
/// increase, a file that cannot be opened or holds no reading. Extra fields are ignored.

#include <string>
#include <vector>

#include "plumb/core/sensor_data.hpp"

namespace plumb::io {

/// @brief How to interpret the two wheel columns.
struct WheelEncoderReadSettings {
  /// 0: columns are cumulative wheel angles [rad]. > 0: columns are cumulative tick counts and are
  /// converted with angle = 2π ticks / ticks_per_revolution.
  double ticks_per_revolution = 0.0;
};

/// @brief Read a wheel encoder CSV file (see the file comment).
/// @throws plumb::Error on unreadable, empty or malformed input, naming the file and line.
std::vector<WheelEncoderReading> read_wheel_encoders(const std::string& path,
                                                     const WheelEncoderReadSettings& settings = {});

/// @brief Parse wheel encoder CSV text; `name` is used in error messages.
std::vector<WheelEncoderReading> parse_wheel_encoders(const std::string& text, const std::string& name,
                                                      const WheelEncoderReadSettings& settings = {});

/// @brief Write readings as `stamp,left,right` (angles in rad, with a header line) in shortest
///        round-trip form, so write/read is lossless.
/// @throws plumb::Error if the file cannot be written.
void write_wheel_encoders(const std::vector<WheelEncoderReading>& readings, const std::string& path);

}  // namespace plumb::io
