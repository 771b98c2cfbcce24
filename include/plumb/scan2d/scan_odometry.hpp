// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Scan-matching odometry: PLICP chained over a sequence of scans with a wheel-odometry
///        prior, matching against a local map of recent keyframes, with a quality gate that falls
///        back to the prior instead of accepting a bad match.

#include <cstddef>
#include <deque>
#include <vector>

#include "plumb/core/pose2.hpp"
#include "plumb/core/laser_scan.hpp"
#include "plumb/scan2d/plicp.hpp"

namespace plumb {

/// @brief How one scan's pose was obtained.
enum class ScanMatchMode {
  kInitial,   ///< first scan: the odometry pose
  kMatched,   ///< PLICP passed the quality gate
  kDegenerate,  ///< PLICP passed the gate but was degenerate: its weak direction taken from the prior
  kPriorFree,  ///< the match from the prior failed the gate, one from a prior-free start passed it
  kFallback,  ///< no match passed the gate: odometry prior used
};

/// @brief Stable lower-case name ("initial", "matched", "degenerate", "prior_free", "fallback").
inline const char* to_string(ScanMatchMode m) {
  switch (m) {
    case ScanMatchMode::kInitial: return "initial";
    case ScanMatchMode::kMatched: return "matched";
    case ScanMatchMode::kDegenerate: return "degenerate";
    case ScanMatchMode::kPriorFree: return "prior_free";
    case ScanMatchMode::kFallback: return "fallback";
  }
  return "unknown";
}

/// @brief Settings of ScanOdometry.
struct ScanOdometrySettings {
  PlicpSettings plicp;                  ///< per-match settings
  PlicpReferenceSettings reference;     ///< local-map neighbour links
  Pose2 T_base_laser;                   ///< laser pose on the robot (l of Liu et al. 2022, eq. 13-14)
  std::size_t local_map_size = 1;       ///< keyframes in the local map (>= 1; 1 = last keyframe only)
  double keyframe_distance = 0.1;       ///< a scan becomes a keyframe after this translation [m] ...
  double keyframe_angle = 0.1;          ///< ... or this rotation since the last keyframe [rad]
  // Quality gate: a match failing any of these is replaced by the odometry prior. A match that
  // hit N_max (kNotConverged, typically a limit cycle between two correspondence sets of a dense
  // local map) is judged by these gates like a converged one; kInsufficientData always fails.
  double min_valid_fraction = 0.4;      ///< kept pairs / valid points
  double max_rmse = 0.05;               ///< sqrt(mse) [m]
  double max_prior_deviation_xy = 0.5;  ///< |match - prior| translation [m]
  double max_prior_deviation_theta = 0.35;  ///< |match - prior| rotation [rad]
  /// When a match is degenerate, keep the prior's component along the weak direction.
  bool prior_along_degenerate_direction = true;
  /// When the match from the prior fails the gate, match again from starts that do not use the
  /// odometry (the last step repeated, and standing still), judged by the same gate around their
  /// own start, and not degenerate: a prior made wrong by wheel slip, a kidnap or stamps that do
  /// not bracket the scan is not trusted over a scan that matches without it.
  bool prior_free_retry = true;
  /// Fuse an accepted, non-degenerate match with the odometry prior in information form: each is
  /// weighted per direction by its covariance, so a direction the scan constrains poorly (along a
  /// corridor, rotation with sparse beams) leans on the wheels and the others on the scan. The
  /// prior's covariance is the larger of the model below and the odometry's running disagreement
  /// with recent matches (wheel odometry whose stamps jitter against the scans is far worse per
  /// step than its drift suggests). Off by default: on the shared CARMEN logs it lowers the
  /// corridor's 10-scan error by about 6 % but adds about 0.5 % to the 1-scan error in rooms (see
  /// docs/results.md); worth turning on where the wheels are good and the scans weak.
  bool fuse_prior = false;
  /// PLICP's covariance assumes independent range errors and is too small for real scans
  /// (correlated errors, noise-made normals along a corridor); it is inflated by this before the
  /// fusion. Conservative: where the scan is well conditioned the match still dominates.
  double match_covariance_scale = 10.0;
  /// A prior whose disagreement with the match exceeds this squared Mahalanobis distance (chi^2,
  /// 3 degrees of freedom; 7.81 = 95 %) is not fused: an odometry glitch the gate let through.
  double fusion_max_chi2 = 7.81;
  double odometry_sigma_xy_per_m = 0.05;       ///< odometry translation noise per metre travelled [m/m]
  double odometry_sigma_xy_min = 0.01;         ///< ... and per step [m]
  double odometry_sigma_theta_per_rad = 0.05;  ///< odometry rotation noise per radian turned [rad/rad]
  double odometry_sigma_theta_per_m = 0.01;    ///< ... per metre travelled [rad/m]
  double odometry_sigma_theta_min = 0.002;     ///< ... and per step [rad]
};

/// @brief The outcome of one scan.
struct ScanOdometryStep {
  Pose2 T_world_base;          ///< robot pose (world = odometry frame at the first scan)
  ScanMatchMode mode = ScanMatchMode::kInitial;
  PlicpResult match;           ///< the PLICP result (default for the first scan)
  double match_ms = 0.0;       ///< wall time of the PLICP call [ms]
};

/// @brief Incremental scan-matching odometry.
///
/// For each scan with its raw odometry pose: the odometry motion (from the scan where the last
/// changed odometry pose arrived, so odometry slower than the scans is applied once, not twice),
/// moved into the laser frame through T_base_laser, predicts the laser pose; PLICP refines it
/// against the local map (the last `local_map_size` keyframes expressed in the newest
/// keyframe's frame); the quality gate accepts the match, optionally fused with the prediction
/// (fuse_prior). When the gate refuses it, the scan is matched again from prior-free starts (the
/// last step repeated, standing still) and the best non-degenerate one passing the gate is taken;
/// only when none does, the prediction is.
/// @note Not thread-safe; one instance per sequence. Deterministic.
class ScanOdometry {
 public:
  explicit ScanOdometry(const ScanOdometrySettings& settings = {});

  /// @brief Process the next scan; `odom_pose` is the raw wheel-odometry robot pose at its stamp.
  /// @throws plumb::Error when odom_pose is not finite or the scan's angles are inconsistent.
  ScanOdometryStep add(const LaserScan& scan, const Pose2& odom_pose);

  /// @brief Current robot pose (identity before the first scan).
  const Pose2& pose() const { return T_world_base_; }
  /// @brief Number of keyframes currently in the local map.
  std::size_t num_keyframes() const { return keyframes_.size(); }

 private:
  struct Keyframe {
    LaserScan scan;
    Pose2 T_world_laser;
  };
  void add_keyframe(const LaserScan& scan, const Pose2& T_world_laser);

  /// The gate: the match is usable and within the deviation budget of its start.
  bool passes_gate(const PlicpResult& m, const Pose2& start) const;
  /// The match and the prior (keyframe frame) fused in information form; `motion` is the
  /// odometry's laser motion of this step. Updates the running odometry residual.
  Pose2 fuse_with_prior(const PlicpResult& m, const Pose2& prior, const Pose2& motion);

  ScanOdometrySettings settings_;
  bool started_ = false;
  Pose2 T_world_base_;
  Pose2 last_motion_;  ///< robot motion of the previous step (identity at the start)
  Pose2 last_odom_;
  Pose2 fresh_odom_;             ///< the last odometry pose that differed from its predecessor
  Pose2 T_world_base_at_fresh_;  ///< the estimate at the scan where it arrived
  /// Running mean of the squared match - prior residual per translation axis [m^2] and in
  /// rotation [rad^2] over recent fused matches (the odometry's noise as the scans see it).
  double residual_xy2_ = 0.0, residual_th2_ = 0.0;
  std::size_t residual_count_ = 0;
  std::deque<Keyframe> keyframes_;
  PlicpReference map_;  ///< in the newest keyframe's laser frame
};

/// @brief Summary of a whole sequence.
struct ScanOdometryResult {
  std::vector<Pose2> poses;            ///< T_world_base per scan
  std::vector<ScanMatchMode> modes;    ///< per scan
  std::vector<int> iterations;         ///< PLICP rounds per scan (0 for the first)
  std::size_t num_matched = 0;         ///< kMatched + kDegenerate
  std::size_t num_degenerate = 0;
  std::size_t num_prior_free = 0;     ///< kPriorFree (counted in num_matched too)
  std::size_t num_fallbacks = 0;
  double mean_iterations = 0.0;        ///< over the matched-or-attempted scans
  double mean_match_ms = 0.0;          ///< PLICP wall time per attempted match [ms]
};

/// @brief Run ScanOdometry over `scans` with the odometry pose of each (same length).
/// @throws plumb::Error when the lengths differ.
ScanOdometryResult run_scan_odometry(const std::vector<LaserScan>& scans,
                                     const std::vector<Pose2>& odometry,
                                     const ScanOdometrySettings& settings = {});

}  // namespace plumb
