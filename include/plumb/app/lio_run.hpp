// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief The LiDAR/IMU hybrid odometry over a frame dump (what `plumb lio` does): HybridLio fed
///        each frame with the dump's IMU up to the end of its sweep, the map started by the first
///        frame with enough points (at gt.tum's pose of that frame when the dump has ground truth),
///        and, with ground truth, the end error, APE and RPE over 10 m, measured with plumb::eval.
///        Its BIM-corrected counterpart is run_bim_odometry() (run.hpp).

#include <array>
#include <cstddef>
#include <functional>
#include <string>
#include <vector>

#include "plumb/core/trajectory.hpp"
#include "plumb/io/frame_dump.hpp"
#include "plumb/pipeline/hybrid_lio.hpp"

namespace plumb {

/// @brief Settings of run_lio().
struct LioRunSettings {
  /// The estimator. T_base_lidar and T_base_imu are taken from the dump's meta.json, and so is
  /// image.vertical_angles_deg when meta.json lists the LiDAR's elevations. `plumb lio` raises
  /// min_init_points to 100: a handful of points would start a map nothing can be matched to.
  HybridLioSettings lio;
  std::size_t max_frames = 0;  ///< 0 = all
  std::function<void(std::size_t done, std::size_t total)> progress;  ///< called after each frame
};

/// @brief Everything a run_lio() run produced.
struct LioRunReport {
  /// Base pose at the stamp of every frame that was not skipped. World frame: gt.tum's when the
  /// dump has ground truth (the map starts at the truth's pose of the first usable frame), else the
  /// base frame of that frame.
  Trajectory trajectory;
  std::vector<LioFrameResult> frames;  ///< one per frame processed, skipped ones included
  std::size_t frames_requested = 0;    ///< frames the run was to process (max_frames or the whole dump)
  std::size_t first_frame = 0;         ///< the frame that started the map (earlier ones were too empty)
  /// A frame failed (e.g. an unreadable frame file) after the map was started: the report covers
  /// frames [0, frames.size()) and `error` says what stopped the run. A failure before that is thrown.
  bool partial = false;
  std::string error;
  /// Data problems that did not stop the run (gt.tum too short), for the caller to show.
  std::vector<std::string> warnings;
  /// Frames per LioFrameMode, indexed by its value (see frames_in()).
  std::array<std::size_t, static_cast<std::size_t>(LioFrameMode::kSkipped) + 1> frames_per_mode{};
  std::size_t imu_gaps = 0;             ///< frames whose interval the IMU did not cover
  std::size_t not_converged = 0;        ///< frames whose solver stopped at its iteration limit
  std::size_t imu_samples_dropped = 0;  ///< IMU samples HybridLio::add_imu() rejected
  /// Wall time of HybridLio::process() over all frames [s] (reading frames excluded), and its
  /// per-frame mean, median (the upper one of an even count) and maximum.
  double seconds_process = 0.0;
  double mean_seconds_process = 0.0, median_seconds_process = 0.0, max_seconds_process = 0.0;
  double frames_per_second = 0.0;  ///< frames / seconds_process
  double mean_plane_points = 0.0;      ///< LioFrameResult::num_plane_points per frame
  double mean_structure_planes = 0.0;  ///< LioFrameResult::num_structure_planes per frame
  // With ground truth (gt.tum):
  bool has_ground_truth = false;
  std::string ground_truth_note = "absent";  ///< "used", "absent" (no gt.tum) or "too_short" (fewer poses than frames)
  /// Ground truth and at least two poses in `trajectory`: the figures below are set. They compare
  /// `trajectory` with gt.tum's poses of the same frames, without alignment.
  bool has_metrics = false;
  double path_length = 0.0;   ///< distance travelled (ground truth) [m]
  double end_error = 0.0;     ///< position error of the last pose [m]
  double end_error_xy = 0.0;  ///< ... horizontal [m]
  double ape_rmse = 0.0;      ///< eval::compute_ape(), translation [m]
  double max_error = 0.0;     ///< largest position error [m]
  /// eval::compute_rpe() over 10 m of the ground truth's path: pairs, translation mean and RMS [m],
  /// rotation mean [deg]. No pair (a path shorter than two steps): all zero.
  std::size_t rpe_pairs = 0;
  double rpe_translation_mean = 0.0, rpe_translation_rmse = 0.0, rpe_rotation_mean_deg = 0.0;

  /// @brief Frames estimated in `mode`.
  std::size_t frames_in(LioFrameMode mode) const { return frames_per_mode[static_cast<std::size_t>(mode)]; }
};

/// @brief Run the LiDAR/IMU hybrid odometry over a frame dump (see the file comment).
///
/// The IMU modes feed HybridLio every sample of imu.csv up to 0.02 s after the end of each frame's
/// sweep (one LiDAR period, 1 / meta rate_hz, 0.1 s when unknown), what a live system has when the
/// sweep is complete. Frames too empty to start the map (fewer than settings.lio.min_init_points
/// points) are skipped; the estimator is made anew at the next frame, given the IMU from one sweep
/// before it on.
/// @throws plumb::Error for a dump without frames, an IMU mode on a dump without imu.csv, gt.tum
///         covering the frames with stamps that are not theirs, no frame with the points to start
///         the map, or a failure before the map was started (a later one gives a partial report,
///         see LioRunReport::partial)
LioRunReport run_lio(const io::FrameDumpReader& dump, const LioRunSettings& settings = {});

}  // namespace plumb
