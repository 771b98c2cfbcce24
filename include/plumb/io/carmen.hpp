// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Reading CARMEN log files (plain text or gzip): laser scans, raw wheel odometry, params.
///
/// One message per line, fields separated by white space. Understood messages:
/// - `FLASER n r_1..r_n x y theta odom_x odom_y odom_theta ipc_timestamp host logger_timestamp`
///   (front laser; beam i at -90 deg + i * res, CARMEN's convention of a 180 deg field of view:
///   res = pi / n for even n (1 deg for 180 beams, 0.5 deg for 360) and pi / (n - 1) for odd n
///   (0.5 deg for 361));
/// - `RAWLASER1..4 laser_type start_angle fov resolution max_range accuracy remission_mode
///    n r_1..r_n m rem_1..rem_m ipc_timestamp host logger_timestamp`;
/// - `ROBOTLASER1 laser_type start_angle fov resolution max_range accuracy remission_mode
///    n r_1..r_n m rem_1..rem_m laser_x laser_y laser_theta robot_x robot_y robot_theta tv rv
///    forward_safety side_safety turn_axis ipc_timestamp host logger_timestamp`;
/// - `ODOM x y theta tv rv accel ipc_timestamp host logger_timestamp`;
/// - `PARAM name value [ipc_timestamp host logger_timestamp]`.
/// Lines starting with `#`, blank lines, `NEFF` and any other message type are skipped.
///
/// The corrected logs of shared/data (SOURCES.md) write an `ODOM` with ipc timestamp exactly 0
/// after each FLASER that repeats the corrected pose: those are counted in
/// CarmenLog::num_repeated_odometry and not kept; every other ODOM is raw wheel odometry.
/// Timestamps are kept as written (the infinite-corridor log has negative and wrapped stamps).

#include <cstddef>
#include <map>
#include <string>
#include <vector>

#include "plumb/core/pose2.hpp"
#include "plumb/core/sensor_data.hpp"
#include "plumb/core/laser_scan.hpp"

namespace plumb::io {

/// @brief Which message a CarmenLaser came from.
enum class CarmenLaserKind { kFlaser, kRawLaser, kRobotLaser };

/// @brief One laser message.
struct CarmenLaser {
  CarmenLaserKind kind = CarmenLaserKind::kFlaser;
  LaserScan scan;          ///< ranges, angles, range_max, stamp = ipc timestamp
  Pose2 pose;              ///< FLASER: (x, y, theta); ROBOTLASER1: laser pose; RAWLASER: zero
  Pose2 odom_pose;         ///< FLASER: odom fields; ROBOTLASER1: robot pose; RAWLASER: zero
  double ipc_timestamp = 0.0;     ///< [s]
  double logger_timestamp = 0.0;  ///< [s]
  std::size_t line = 0;           ///< 1-based line in the file
  /// Number of raw ODOM messages that precede this laser in the file (index of the next one).
  std::size_t num_odometry_before = 0;
};

/// @brief One raw wheel-odometry message (ODOM with ipc timestamp != 0).
struct CarmenOdometry {
  Pose2 pose;                  ///< odometry pose of the robot [m, rad]
  double tv = 0.0;             ///< translational velocity [m/s]
  double rv = 0.0;             ///< rotational velocity [rad/s]
  double accel = 0.0;          ///< [m/s^2]
  double ipc_timestamp = 0.0;  ///< [s]
  double logger_timestamp = 0.0;  ///< [s]
  std::size_t line = 0;        ///< 1-based line in the file
};

/// @brief Everything read from a log, in file order.
struct CarmenLog {
  std::vector<CarmenLaser> lasers;          ///< FLASER, RAWLASER*, ROBOTLASER1 in file order
  std::vector<CarmenOdometry> odometry;     ///< raw ODOM messages in file order
  std::map<std::string, std::string> params;  ///< PARAM name -> value (last one wins)
  std::size_t num_repeated_odometry = 0;    ///< ODOM lines with timestamp 0 (ignored)
  std::size_t num_skipped = 0;              ///< NEFF and unknown message lines

  /// @brief Number of lasers of one kind.
  std::size_t count(CarmenLaserKind kind) const {
    std::size_t n = 0;
    for (const auto& l : lasers) n += l.kind == kind ? 1 : 0;
    return n;
  }
};

/// @brief Options of the CARMEN reader.
struct CarmenReadSettings {
  /// FLASER carries no maximum range; readings >= this are "no return" (the logs write the
  /// sensor's maximum, ~50-82 m, then) [m]. Also caps RAWLASER/ROBOTLASER1's own maximum range.
  double flaser_range_max = 50.0;
  /// A gzip log is inflated in memory before it is parsed; inflating stops with an error past
  /// this many bytes of text, so a small corrupt or hostile file cannot take minutes and
  /// gigabytes (deflate reaches ~1000:1). The default, 4 GiB, is ~40x the largest shared log.
  std::size_t max_inflated_bytes = std::size_t{4} << 30;
};

/// @brief Read a CARMEN log, plain text or gzip (detected from the content, not the name).
/// @throws plumb::Error naming the file and 1-based line for a malformed message (wrong field
///         count, a field that is not a number, a negative beam count), or when the file cannot
///         be opened or read.
CarmenLog read_carmen(const std::string& path, const CarmenReadSettings& settings = {});

/// @brief read_carmen() on the bytes of a file held in memory, plain text or gzip (one or more
///        members, as `cat a.gz b.gz` makes; bytes after the last member that do not start another
///        one are ignored, as gzread() does); `name` stands for the path in messages.
/// @throws plumb::Error as read_carmen(); for corrupt or truncated gzip data, or gzip data that
///         inflates to more than `settings.max_inflated_bytes`, naming `name`.
CarmenLog read_carmen_buffer(const char* data, std::size_t size, const std::string& name,
                             const CarmenReadSettings& settings = {});

/// @brief Parse CARMEN log text held in memory; `name` is used in error messages.
/// @throws plumb::Error as read_carmen().
CarmenLog parse_carmen(const std::string& text, const std::string& name = "<carmen>",
                       const CarmenReadSettings& settings = {});

/// @brief Raw odometry pose at each laser's stamp, interpolated in SE(2).
///
/// For laser k the two raw ODOM messages around it in file order (the last one before and the
/// first one after) are interpolated at the laser's ipc stamp (interpolate_pose2) when their
/// stamps bracket it; when they do not (broken timestamps) or one side is missing, the nearer
/// message in file order is used as is.
/// @throws plumb::Error when the log has lasers but no raw odometry.
std::vector<Pose2> raw_odometry_at_lasers(const CarmenLog& log);

using plumb::interpolate_pose2;  // plumb/core/sensor_data.hpp

}  // namespace plumb::io
