// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Trajectory error metrics with evo's semantics: association by stamp, APE, RPE, error
///        statistics, and drift as a percentage of the distance travelled (Liu et al. 2022, Table 2).

#include <cstddef>
#include <utility>
#include <vector>

#include "plumb/core/status.hpp"
#include "plumb/core/trajectory.hpp"
#include "plumb/eval/align.hpp"

namespace plumb::eval {

/// @brief Summary statistics of a list of errors, as numpy computes them.
struct ErrorStats {
  double rmse = 0.0;    ///< sqrt(mean(e^2))
  double mean = 0.0;
  double median = 0.0;  ///< mean of the two middle values for an even count
  double std = 0.0;     ///< population standard deviation (numpy's default ddof = 0)
  double min = 0.0;
  double max = 0.0;
  double sse = 0.0;     ///< sum of e^2
  std::size_t count = 0;
};

/// @brief Statistics of `errors`.
/// @throws plumb::Error when `errors` is empty or holds a NaN or an infinity.
ErrorStats compute_stats(const std::vector<double>& errors);

/// @brief How two trajectories are paired pose by pose.
struct AssociationSettings {
  double max_time_difference = 0.01;  ///< largest accepted |stamp_est - stamp_ref| [s] (evo's default)
  double time_offset = 0.0;           ///< added to the estimate's stamps before matching [s]
  /// Fewest pose pairs accepted: fewer cannot be aligned (SE(3) needs 3 non-collinear positions)
  /// and give no meaningful statistics.
  std::size_t min_pairs = 3;
  /// Fewest pose pairs accepted, as a share of the shorter trajectory's poses: a lower share means
  /// the two barely overlap in time or their stamps are in different units or clocks (ms against
  /// s), and errors over the few chance matches would look valid. 0 disables the check.
  double min_pair_fraction = 0.5;
};

/// @brief Two trajectories cut to the associated poses, pose i of one with pose i of the other.
struct AssociationResult {
  Trajectory estimate;
  Trajectory reference;
  std::vector<std::size_t> estimate_indices;   ///< original index of each kept estimate pose
  std::vector<std::size_t> reference_indices;  ///< original index of each kept reference pose
  bool by_stamp = false;                       ///< false: paired by index
};

/// @brief Pair the poses of an estimate and a reference.
///
/// When both carry stamps: each pose of the shorter trajectory takes the pose of the longer one
/// with the nearest stamp (the earlier one on a tie), kept if within max_time_difference (evo's
/// `associate_trajectories`; a pose of the longer trajectory may be used twice). Otherwise the two
/// must have the same size and are paired by index (KITTI without times files); a trajectory
/// without stamps then takes the other's stamps.
/// @throws plumb::Error when stamps are missing and sizes differ; when stamps are present but do
///         not strictly increase (the message names the pose); when a pose is not finite; or when
///         fewer pairs than AssociationSettings::min_pairs or min_pair_fraction of the shorter
///         trajectory are found (the message gives both counts and the stamp ranges). Messages
///         start with "associate:"; callers add the file names.
AssociationResult associate(const Trajectory& estimate, const Trajectory& reference,
                            const AssociationSettings& settings = {});

/// @brief Per-pose errors of one kind and their statistics.
struct ErrorSeries {
  std::vector<double> values;
  ErrorStats stats;
};

/// @brief Which components of a position difference a translational error or a path length measures.
enum class PositionAxes {
  kXYZ,  ///< the 3-D distance
  /// x and y only: the horizontal error of a ground robot, whose height the floor fixes (the error of
  /// Liu et al. 2022, Table 2); a z offset of the estimate's frame does not count.
  kXY,
};

/// @brief Settings of the absolute pose error.
struct ApeSettings {
  AlignMode align = AlignMode::kSE3;  ///< alignment fitted on the positions before measuring
  PositionAxes axes = PositionAxes::kXYZ;  ///< components of the `translation` error
};

/// @brief Absolute pose error of an (associated) estimate against its reference.
///
/// With E_i = P_est_i^-1 P_ref_i after alignment (evo's APE): `translation` = |p_est_i - p_ref_i|
/// [m] over ApeSettings::axes (its `stats.max` is the largest position error); `rotation_deg` = rotation angle of E_i [deg]; `full` = ||E_i - I||_F (unit-less, as evo's
/// "full transformation").
struct ApeResult {
  ErrorSeries translation;   ///< [m]
  ErrorSeries rotation_deg;  ///< [deg]
  ErrorSeries full;          ///< unit-less
  UmeyamaResult alignment;   ///< the similarity applied to the estimate (identity for kNone)
  /// The alignment's status: kDegenerate for (nearly) collinear positions, kInsufficientData for
  /// a single pose. The errors are still computed, but with an arbitrary rotation about the line:
  /// callers should refuse them (or use AlignMode::kNone).
  Status status = Status::kOk;
};

/// @brief APE of `estimate` against `reference` (same size, pose i with pose i; see associate()).
/// @throws plumb::Error when the sizes differ or the trajectories are empty.
ApeResult compute_ape(const Trajectory& estimate, const Trajectory& reference,
                      const ApeSettings& settings = {});

/// @brief Which trajectory measures distance travelled (RPE pairs in metres, drift).
enum class PathSource {
  kReference,  ///< the ground truth
  kEstimate,   ///< the estimate itself (e.g. odometry summed frame by frame, as Liu et al. 2022 do)
};

/// @brief Unit of the RPE step.
enum class DeltaUnit {
  kFrames,  ///< index distance
  kMeters,  ///< path length travelled [m], along RpeSettings::pairs_along
};

/// @brief Settings of the relative pose error.
struct RpeSettings {
  double delta = 1.0;                     ///< step, in `unit` (an integer >= 1 for frames)
  DeltaUnit unit = DeltaUnit::kFrames;
  AlignMode align = AlignMode::kNone;     ///< alignment applied first (only kSim3's scale matters)
  /// Path along which metre deltas are measured. evo measures it along the estimate (its
  /// `RPE.process_data` passes `traj_est.poses_se3` to `id_pairs_from_delta`), and only that
  /// reproduces evo's published KITTI 00 numbers, hence the default.
  PathSource pairs_along = PathSource::kEstimate;
};

/// @brief Pairs of indices (i, j) for the RPE, without overlap, as evo chooses them with
///        all_pairs = false.
///
/// Frames: (0, d), (d, 2d), ... Metres: the path length is accumulated pose by pose along
/// `trajectory`; each time it reaches `delta` that index is marked and the sum restarts from it;
/// the pairs join consecutive marks. The first mark is the first index at least `delta` from
/// index 0 along the path (index 0 itself is not a mark, exactly as in evo).
/// @throws plumb::Error for delta <= 0 or a fractional frame delta.
std::vector<std::pair<std::size_t, std::size_t>> rpe_pairs(const Trajectory& trajectory, double delta,
                                                           DeltaUnit unit);

/// @brief Relative pose error.
///
/// For every pair (i, j) of rpe_pairs(estimate or reference, ...), E = (Q_i^-1 Q_j)^-1 (P_i^-1 P_j), Q the
/// reference, P the estimate (TUM RGB-D benchmark, Sturm et al. 2012, eq. 1; evo's RPE):
/// `translation` = |t(E)| [m], `rotation_deg` = angle(E) [deg], `full` = ||E - I||_F.
struct RpeResult {
  ErrorSeries translation;   ///< [m]
  ErrorSeries rotation_deg;  ///< [deg]
  ErrorSeries full;          ///< unit-less
  std::vector<std::pair<std::size_t, std::size_t>> pairs;
  /// kOk, or kInsufficientData when no pair fits (delta longer than the path); the series are
  /// then empty and their stats zero.
  Status status = Status::kOk;
};

/// @brief RPE of `estimate` against `reference` (same size, pose i with pose i).
/// @throws plumb::Error when the sizes differ, the trajectories are empty, or settings are invalid.
RpeResult compute_rpe(const Trajectory& estimate, const Trajectory& reference,
                      const RpeSettings& settings = {});

/// @brief Cumulative path length: element i is the length of the polyline through positions 0..i
///        (element 0 is 0) [m], measured over `axes` (kXY: the length of its floor-plan projection).
std::vector<double> path_lengths(const Trajectory& trajectory, PositionAxes axes = PositionAxes::kXYZ);

/// @brief Settings of drift_at().
struct DriftSettings {
  PathSource path = PathSource::kReference;  ///< whose path length is "distance travelled"
  PositionAxes axes = PositionAxes::kXYZ;    ///< components of both the error and the path length
};

/// @brief Drift at one index: the position error as a share of the distance travelled so far.
struct DriftSample {
  std::size_t index = 0;
  double path_length = 0.0;  ///< distance travelled from index 0 to `index` [m]
  double error = 0.0;        ///< |p_est - p_ref| over DriftSettings::axes [m]
  double drift_pct = 0.0;    ///< error / path_length * 100; NaN when path_length is 0
};

/// @brief Drift (Liu et al. 2022, Table 2: |p_est - p_ref| / distance travelled so far * 100) at each index.
/// @note The estimate is used as given: align it first if it is not in the reference's frame.
/// @throws plumb::Error when the sizes differ, trajectories are empty or an index is out of range.
std::vector<DriftSample> drift_at(const Trajectory& estimate, const Trajectory& reference,
                                  const std::vector<std::size_t>& indices,
                                  const DriftSettings& settings = {});

/// @brief Index of the pose whose stamp is nearest to `stamp` (the earlier one on a tie).
/// @throws plumb::Error when the trajectory has no stamps.
std::size_t nearest_index(const Trajectory& trajectory, double stamp);

}  // namespace plumb::eval
