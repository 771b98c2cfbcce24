// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Range image of a spinning multi-ring LiDAR frame (Zhou et al. 2021, sec. 1.1, eq. 1-4):
/// rows are laser rings, columns are azimuth bins, and every pixel keeps the index of the point it
/// holds.

#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

#include "plumb/core/point_cloud.hpp"
#include "plumb/core/status.hpp"

namespace plumb {

/// @brief Where the row (ring) of a point comes from.
enum class RingSource {
  kAuto,            ///< the cloud's ring field when present, else vertical_angles_deg when given, else auto-binning
  kField,           ///< the cloud's ring field (a cloud without one is a plumb::Error)
  kVerticalAngles,  ///< nearest of the sensor's vertical angles (settings.vertical_angles_deg)
  kAutoBin,         ///< clusters of the points' elevation angles, separated by gaps > auto_bin_gap_deg
};

/// @brief Settings of build_range_image().
struct RangeImageSettings {
  RingSource ring_source = RingSource::kAuto;  ///< see RingSource
  /// Number of rows when the ring field is used; 0 = largest ring value + 1. A ring value >= this
  /// is a plumb::Error.
  int num_rings = 0;
  /// The sensor's vertical (elevation) angles [deg], any order; row r is the r-th smallest angle.
  /// Used by RingSource::kVerticalAngles and by kAuto on clouds without a ring field.
  std::vector<double> vertical_angles_deg;
  /// A point farther than this from its nearest vertical angle gets no row (dropped) [deg].
  double max_vertical_angle_error_deg = 1.0;
  /// Auto-binning: sorted elevations separated by more than this start a new ring [deg].
  double auto_bin_gap_deg = 0.4;
  /// Auto-binning: elevation clusters with fewer points are treated as stray points (dropped).
  std::size_t auto_bin_min_points = 16;
  /// Azimuth resolution [deg], in [0.006, 360]: the image has ceil(360 / this) columns (the sensor
  /// of Zhou et al. 2021, sec. 4: 0.2).
  double horizontal_resolution_deg = 0.2;
  double min_range = 0.5;    ///< points closer to the sensor are dropped (self hits, zeros) [m]
  double max_range = 200.0;  ///< points farther away are dropped [m]
};

/// @brief A range image: `num_rows` rings (row 0 = lowest elevation) by `num_columns` azimuth bins.
///
/// Azimuth follows Zhou et al. 2021, eq. 1-4: `x = l cos(alpha) sin(beta)`, `y = l cos(alpha) cos(beta)`,
/// `z = l sin(alpha)`, so `beta = atan2(x, y)` in [0, 2 pi), measured from +y towards +x; column
/// `c = floor(beta / resolution)`. When two points fall into one pixel the nearer one is kept.
struct RangeImage {
  static constexpr std::int32_t kEmpty = -1;                    ///< pixel without a point
  static constexpr std::uint16_t kNoRing = 0xFFFF;              ///< point without a row

  int num_rows = 0;      ///< rings
  int num_columns = 0;   ///< azimuth bins
  std::vector<std::int32_t> index;  ///< row-major num_rows x num_columns: point index or kEmpty
  std::vector<float> range;         ///< row-major: range of the pixel's point [m], +inf when empty
  std::vector<std::uint16_t> point_row;  ///< per input point: its row, or kNoRing when dropped
  std::vector<std::uint16_t> point_column;  ///< per input point: its column (valid when point_row is)
  std::vector<double> row_elevation;  ///< mean elevation of the points in each row [rad] (0 for an empty row)
  std::size_t num_pixels_filled = 0;     ///< pixels holding a point
  std::size_t num_dropped = 0;           ///< points with a non-finite coordinate, out of range, or no row
  std::size_t num_collisions = 0;        ///< points that lost their pixel to a nearer point
  /// kOk when at least one pixel is filled; kInsufficientData otherwise (empty or all-invalid frame).
  Status status = Status::kInsufficientData;

  /// @brief Point index at (row, column), or kEmpty.
  std::int32_t at(int row, int column) const {
    return index[static_cast<std::size_t>(row) * static_cast<std::size_t>(num_columns) +
                 static_cast<std::size_t>(column)];
  }
  /// @brief Range at (row, column) [m], +inf when empty.
  float range_at(int row, int column) const {
    return range[static_cast<std::size_t>(row) * static_cast<std::size_t>(num_columns) +
                 static_cast<std::size_t>(column)];
  }
};

/// @brief Sort an unordered multi-ring frame into a range image (Zhou et al. 2021, eq. 1-4).
/// @param cloud the frame in the sensor frame (origin at the optical centre)
/// @param settings see RangeImageSettings
/// @return the image; an empty or all-invalid frame gives Status::kInsufficientData, never a throw
/// @throws plumb::Error on misuse: inconsistent cloud fields, RingSource::kField without a ring
///         field or with a ring >= num_rings, kVerticalAngles without angles, bad settings
/// @note O(n) (O(n log n) with auto-binning); deterministic; no shared state.
RangeImage build_range_image(const PointCloud& cloud, const RangeImageSettings& settings = {});

/// @brief The row of each point by auto-binning its elevation angle (see RingSource::kAutoBin).
/// @param num_rows receives the number of rings found
/// @return per point: its row, or RangeImage::kNoRing for invalid or stray points
std::vector<std::uint16_t> auto_bin_rings(const PointCloud& cloud, const RangeImageSettings& settings,
                                          int& num_rows);

}  // namespace plumb
