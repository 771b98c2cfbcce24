// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Spinning multi-beam LiDAR models and one simulated revolution (sweep) in a World.

#include <functional>
#include <string>
#include <vector>

#include "plumb/core/point_cloud.hpp"
#include "plumb/core/rng.hpp"
#include "plumb/core/types.hpp"
#include "plumb/sim/world.hpp"

namespace plumb::sim {

/// @brief A spinning LiDAR: one column of beams fired at a time, columns evenly spread over one
/// revolution, the head turning counter-clockwise seen from above (+z) at `rate_hz`.
///
/// LiDAR frame: x forward (azimuth 0 = first column), y left, z up. Beam (row r, column c) points
/// along (cos el cos az, cos el sin az, sin el) with el = elevations_rad[r] and
/// az = azimuth_offset_rad + 2 pi c / columns, and is fired at c / (columns rate_hz) s after the
/// sweep stamp (all rows of a column at once).
struct LidarModel {
  std::string name;                   ///< preset name or user's label
  std::vector<double> elevations_rad; ///< elevation of each row (ring) [rad]; ring index = row
  int columns = 1800;                 ///< firings per revolution
  double rate_hz = 10.0;              ///< revolutions per second [Hz], in [kMinRateHz, kMaxRateHz]
  double min_range = 0.3;             ///< returns closer than this are dropped [m]
  double max_range = 100.0;           ///< no return beyond this [m]
  double range_sigma = 0.01;          ///< range noise, standard deviation [m]
  double dropout = 0.0;               ///< probability that a return is lost, in [0, 1]
  double azimuth_offset_rad = 0.0;    ///< azimuth of column 0 [rad]

  std::size_t num_rays() const { return elevations_rad.size() * static_cast<std::size_t>(columns); }
  /// @brief Duration of one revolution [s].
  double sweep_duration() const { return 1.0 / rate_hz; }
  /// Limits validate() enforces: every sweep and every simulation stays bounded (real spinning
  /// LiDARs turn at 5-20 Hz and fire at most a few hundred thousand rays per sweep).
  static constexpr double kMinRateHz = 1.0, kMaxRateHz = 100.0;
  static constexpr std::size_t kMaxRows = 65535;  ///< the ring index is 16 bits
  static constexpr int kMaxColumns = 100000;
  static constexpr std::size_t kMaxRaysPerSweep = std::size_t{1} << 22;
  /// @brief Throw plumb::Error naming the field when a value is out of range (see the limits above).
  void validate() const;
};

/// @brief Names accepted by lidar_preset().
std::vector<std::string> lidar_preset_names();

/// @brief A preset sensor model.
///
/// - `rfans32`: Surestar R-Fans-32 class, 32 rows evenly from -20 deg to +10 deg (assumed layout:
///   the data sheet's 30 deg vertical field, 0.97 deg apart), 2000 columns, 10 Hz, 0.3..150 m,
///   sigma 2 cm.
/// - `vlp16`: Velodyne VLP-16, 16 rows -15..+15 deg (2 deg apart), 1800 columns (0.2 deg), 10 Hz,
///   0.5..100 m, sigma 3 cm.
/// - `os1-64`: Ouster OS1-64, 64 rows -16.6..+16.6 deg, 1024 columns, 10 Hz, 0.3..120 m, sigma 3 cm.
/// @throws plumb::Error for an unknown name, listing the known ones.
LidarModel lidar_preset(const std::string& name);

/// @brief Settings of simulate_sweep().
struct SweepSettings {
  bool motion_distortion = true;  ///< fire each column from the pose at its own time; false = every
                                  ///< column from the pose at the stamp (an ideal, undistorted frame)
  bool noise = true;              ///< add range noise (LidarModel::range_sigma)
  bool dropouts = true;           ///< drop returns with probability LidarModel::dropout
  double max_incidence_rad = 1.5533;  ///< returns hitting a surface more obliquely than this are lost [rad] (89 deg)
};

/// @brief One revolution of `lidar` in `world`, starting at `stamp`.
///
/// The LiDAR pose at time stamp + dt is `T_world_lidar(stamp + dt)`; the caller interpolates its
/// trajectory. Each point is expressed in the LiDAR frame AT ITS OWN TIME, as a real sensor reports
/// it, so motion during the sweep distorts the frame. Rays without a return (miss, beyond
/// max_range, closer than min_range, dropout, grazing) are dropped.
/// @return cloud with points [m], intensities (0..255, from the surface class and the cosine of the
///         incidence angle), rings (row index), times (s since `stamp`) and labels (SimLabel), in
///         firing order (column by column, rows in order).
/// @note Deterministic for a given rng state; rng is drawn only for noise and dropouts, in firing
///       order. O(num_rays * log(triangles)).
PointCloud simulate_sweep(const World& world, const LidarModel& lidar,
                          const std::function<Eigen::Isometry3d(double)>& T_world_lidar, double stamp,
                          Rng& rng, const SweepSettings& settings = {});

}  // namespace plumb::sim
