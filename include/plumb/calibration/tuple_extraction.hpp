// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Calibration tuples from a log: laser scans + wheel encoder readings -> (T, φ_L, φ_R, ŝ)
///        (the role of the synchronizer of Censi's calibration tool).
///
/// For each pair of scans (k, k + scan_spacing) the wheel angles are interpolated linearly at the
/// two scan stamps from the encoder stream (cumulative wheel angles), giving the interval
/// T = t_{k+Δ} - t_k and the mean wheel speeds φ = Δangle / T. The laser motion ŝ comes from a
/// scan matcher supplied by the caller (e.g. PLICP), started from the motion the nominal
/// parameters predict, s = ⊖l ⊕ r ⊕ l. Pairs whose stamps are not covered by encoder readings
/// (or fall in a gap between readings longer than max_encoder_gap), and pairs the matcher
/// refuses, give no tuple and are counted; so do pairs whose wheel speeds change within the
/// interval (the tuple model assumes constant speeds).

#include <cmath>
#include <cstddef>
#include <functional>
#include <optional>
#include <vector>

#include "plumb/calibration/odometry_laser.hpp"
#include "plumb/core/error.hpp"
#include "plumb/core/sensor_data.hpp"
#include "plumb/core/status.hpp"
#include "plumb/core/laser_scan.hpp"
#include "plumb/scan2d/plicp.hpp"

namespace plumb {

/// @brief A scan matcher: the pose of `current`'s laser frame in `reference`'s laser frame, or
///        nothing when the match failed. `guess` is the predicted motion.
using ScanMatcher = std::function<std::optional<Pose2>(const LaserScan& reference, const LaserScan& current,
                                                       const Pose2& guess)>;

/// @brief A ScanMatcher running PLICP (plumb/scan2d/plicp.hpp) of the later scan against the
///        earlier one from the guess. It accepts only Status::kOk matches, and refuses matches
///        flagged degenerate (corridors) unless accept_degenerate: a calibration tuple with a wrong
///        laser motion costs more than a missing one.
ScanMatcher plicp_scan_matcher(const PlicpSettings& settings = {}, bool accept_degenerate = false);

/// @brief Settings of extract_calibration_tuples().
struct TupleExtractionSettings {
  /// Match scan k against scan k + scan_spacing (>= 1). Longer spans give larger motions (better
  /// conditioned tuples) as long as the scans still overlap.
  std::size_t scan_spacing = 1;
  /// A scan stamp must lie between two encoder readings at most this far apart [s] (Censi's
  /// synchronizer: time_tolerance 0.5).
  double max_encoder_gap = 0.5;
  /// Drop pairs whose wheel speeds were not constant: the tuple model (Censi et al.) integrates
  /// constant wheel speeds over the interval, and a pair spanning an acceleration, a stop or a
  /// reversal gives a tuple whose motion the model cannot explain. The mean speed over each half of
  /// the interval is compared; a pair is dropped when the two differ, for either wheel, by more than
  /// max_speed_change + max_speed_change_ratio · (larger mean wheel speed) [rad/s].
  bool check_constant_speed = true;
  double max_speed_change = 0.05;       ///< [rad/s], absorbs encoder quantisation
  double max_speed_change_ratio = 0.05; ///< relative part of the tolerance
  /// Nominal parameters used only to predict the laser motion for the matcher's first guess.
  /// With the default (all zero) the guess is the identity for scan_spacing 1, and for larger
  /// spacings the composition of the matcher's scan-to-next-scan motions (one extra match per scan).
  OdometryLaserParams nominal;
};

/// @brief Tuples and what happened to the scan pairs.
struct TupleExtractionResult {
  /// kOk when at least one tuple was made; kInsufficientData otherwise.
  Status status = Status::kInsufficientData;
  std::vector<CalibrationTuple> tuples;
  /// (reference, current) scan indices of each tuple.
  std::vector<std::pair<std::size_t, std::size_t>> scan_pairs;
  std::size_t num_pairs = 0;            ///< scan pairs considered
  std::size_t num_without_odometry = 0; ///< pairs skipped: stamps not covered by encoder readings
  std::size_t num_speed_changes = 0;    ///< pairs skipped: wheel speeds not constant (see settings)
  std::size_t num_match_failures = 0;   ///< pairs the matcher refused
};

/// @brief Wheel angles (left, right) at time t by linear interpolation, or nothing when t is not
///        inside [first, last] reading or the two readings around it are farther apart than
///        max_gap. `readings` must be sorted by stamp.
std::optional<Vector2d> interpolate_wheel_angles(const std::vector<WheelEncoderReading>& readings, double t,
                                                 double max_gap);

/// @brief Make calibration tuples from scans and wheel encoder readings (see the file comment).
/// @param scans laser scans in time order
/// @param wheels encoder readings in time order
/// @param matcher scan matcher (called once per usable pair, in scan order)
/// @throws plumb::Error when stamps are not increasing (naming the index), when scan_spacing is 0
///         or max_encoder_gap <= 0.
TupleExtractionResult extract_calibration_tuples(const std::vector<LaserScan>& scans,
                                                 const std::vector<WheelEncoderReading>& wheels,
                                                 const ScanMatcher& matcher,
                                                 const TupleExtractionSettings& settings = {});

}  // namespace plumb
