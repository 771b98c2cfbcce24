// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief LaserScan: one planar range scan (ranges in beam order, their angles, stamp, limits)
///        and its conversion to 2D points in the laser frame.

#include <cmath>
#include <cstddef>
#include <limits>
#include <vector>

#include "plumb/core/error.hpp"
#include "plumb/core/types.hpp"

namespace plumb {

/// @brief One planar laser scan in the laser frame (x forward, y left, angles counter-clockwise).
///
/// Beam i has range `ranges[i]` [m] at angle `angle(i)` [rad]: `angles[i]` when `angles` is not
/// empty (irregular scans, e.g. CSM JSON), else `angle_min + i * angle_increment`.
/// A beam is valid when its range is finite and `range_min < r < range_max`: a reading at or
/// beyond `range_max` means "no return" (CARMEN logs write the sensor's maximum value then).
/// Beams are expected in increasing angle order; PLICP uses the order to pair neighbouring points.
struct LaserScan {
  std::vector<float> ranges;     ///< [m], one per beam, in beam order
  std::vector<float> angles;     ///< [rad], empty (regular scan) or one per beam
  double angle_min = 0.0;        ///< angle of beam 0 for a regular scan [rad]
  double angle_increment = 0.0;  ///< angle between beams for a regular scan [rad]
  double range_min = 0.0;        ///< readings <= this are invalid [m]
  double range_max = std::numeric_limits<double>::infinity();  ///< readings >= this: no return [m]
  double stamp = 0.0;            ///< acquisition time [s]

  /// @brief Number of beams.
  std::size_t size() const { return ranges.size(); }
  bool empty() const { return ranges.empty(); }

  /// @brief Angle of beam i [rad].
  double angle(std::size_t i) const {
    return angles.empty() ? angle_min + static_cast<double>(i) * angle_increment
                          : static_cast<double>(angles[i]);
  }

  /// @brief True when beam i holds a usable return (finite, strictly inside (range_min, range_max)).
  bool valid(std::size_t i) const {
    const double r = ranges[i];
    return std::isfinite(r) && r > range_min && r < range_max && std::isfinite(angle(i));
  }

  /// @brief Number of valid beams.
  std::size_t num_valid() const {
    std::size_t n = 0;
    for (std::size_t i = 0; i < ranges.size(); ++i) n += valid(i) ? 1 : 0;
    return n;
  }

  /// @brief Point of beam i in the laser frame [m] (no validity check).
  Vector2d point(std::size_t i) const {
    const double a = angle(i), r = ranges[i];
    return {r * std::cos(a), r * std::sin(a)};
  }

  /// @brief Throw plumb::Error when `angles` is neither empty nor one per beam.
  void check_consistent(const char* where = "LaserScan") const {
    PLUMB_CHECK(angles.empty() || angles.size() == ranges.size(),
                where << ": " << angles.size() << " angles for " << ranges.size() << " ranges");
  }

  /// @brief The valid beams as 2D points in the laser frame, in beam order.
  /// @param beam_indices if not null, receives the beam index of each returned point
  std::vector<Vector2d> to_points(std::vector<std::size_t>* beam_indices = nullptr) const {
    check_consistent("LaserScan::to_points");
    std::vector<Vector2d> points;
    points.reserve(ranges.size());
    if (beam_indices != nullptr) beam_indices->clear();
    for (std::size_t i = 0; i < ranges.size(); ++i) {
      if (!valid(i)) continue;
      points.push_back(point(i));
      if (beam_indices != nullptr) beam_indices->push_back(i);
    }
    return points;
  }
};

}  // namespace plumb
