// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief KITTI odometry benchmark errors: relative errors over path segments of fixed length
///        (Geiger et al., CVPR 2012, section 2.3; the devkit's `evaluate_odometry`).

#include <cstddef>
#include <vector>

#include "plumb/core/status.hpp"
#include "plumb/core/trajectory.hpp"

namespace plumb::eval {

/// @brief Segment lengths and spacing of the KITTI evaluation.
struct KittiSegmentSettings {
  std::vector<double> lengths = {100, 200, 300, 400, 500, 600, 700, 800};  ///< segment lengths [m]
  std::size_t step_frames = 10;  ///< distance between the first frames of segments [frames]
};

/// @brief The error of one segment, normalised by its length.
struct KittiSegmentError {
  std::size_t first_frame = 0;
  std::size_t last_frame = 0;
  double length = 0.0;             ///< nominal segment length [m]
  double translation_error = 0.0;  ///< |t(E)| / length [m/m]
  double rotation_error = 0.0;     ///< angle(E) / length [rad/m]
};

/// @brief Average errors of one segment length.
struct KittiLengthAverage {
  double length = 0.0;               ///< [m]
  std::size_t num_segments = 0;
  double translation_pct = 0.0;      ///< mean translation_error * 100 [%]
  double rotation_deg_per_m = 0.0;   ///< mean rotation_error in [deg/m]
};

/// @brief All segment errors and their averages.
struct KittiSegmentResult {
  std::vector<KittiSegmentError> segments;
  std::vector<KittiLengthAverage> per_length;  ///< lengths with at least one segment, in settings order
  double translation_pct = 0.0;     ///< mean over all segments of translation_error * 100 [%]
  double rotation_deg_per_m = 0.0;  ///< mean over all segments of rotation_error [deg/m]
  /// kOk, or kInsufficientData when the path is shorter than every segment length (no segment).
  Status status = Status::kOk;
};

/// @brief KITTI segment errors of `estimate` against `reference` (same size, pose i with pose i).
///
/// For first frames 0, step, 2 step, ... and each length L: the last frame is the first whose
/// distance along the reference exceeds the first frame's by more than L (strictly); E =
/// (P_f^-1 P_l)^-1 (Q_f^-1 Q_l) with P the estimate and Q the reference; rotation angle from
/// acos((trace(R_E) - 1) / 2) clamped to [-1, 1], as the devkit, but in double precision.
/// @throws plumb::Error when the sizes differ, the trajectories are empty, or settings are invalid.
KittiSegmentResult compute_kitti_segment_errors(const Trajectory& estimate, const Trajectory& reference,
                                                const KittiSegmentSettings& settings = {});

}  // namespace plumb::eval
