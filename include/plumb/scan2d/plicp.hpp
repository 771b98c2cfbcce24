// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief PLICP: point-to-line ICP between planar scans (Liu et al. 2022, sec. 3.2, eq. 15-18; Censi, "An ICP
///        variant using a point-to-line metric", ICRA 2008).
///
/// Frames: the *reference* frame is the laser frame of the reference scan (or of a local map);
/// the *current* frame is the laser frame of the scan being matched. The result `T_ref_cur`
/// maps current-frame points into the reference frame, i.e. it is the pose of the current laser
/// in the reference laser frame (for consecutive scans: the laser's motion s = ⊖l ⊕ r ⊕ l).
///
/// Typical use:
/// @code
///   PlicpReference ref(previous_scan);                  // builds a 2D kd-tree once
///   Pose2 guess = laser_motion(odom_motion, T_base_laser);  // wheel-odometry prior
///   PlicpResult r = plicp(current_scan, ref, guess);
///   if (r.status == Status::kOk) use(r.T_ref_cur, r.covariance);
/// @endcode

#include <cstddef>
#include <vector>

#include "plumb/core/pose2.hpp"
#include "plumb/core/status.hpp"
#include "plumb/core/types.hpp"
#include "plumb/core/laser_scan.hpp"
#include "plumb/search/kdtree.hpp"

namespace plumb {

/// @brief How reference points are linked to their neighbours along the scan.
struct PlicpReferenceSettings {
  /// Two consecutive valid beams of a scan are neighbours on one surface (so may form a
  /// correspondence segment) only when their points are closer than this [m].
  double max_neighbor_distance = 0.5;
  /// Farther apart, they are still neighbours when closer than this many times the spacing their
  /// beams would have on a surface facing the laser (range x angle between the beams): a wall seen
  /// at grazing incidence far away (a corridor's, with 1 deg beams) keeps its segments. 0 = off.
  double grazing_factor = 3.0;
  /// A point's smoothed normal is the chord to the nearest neighbours at least this far away on
  /// each side, which averages out range noise on dense scans [m]. Past the 16th neighbour the
  /// walk to them takes strides of 1/16 of the way walked, so the chord may reach ~6 % beyond
  /// the baseline and the cost grows with the log, not the number, of beams within it. A match's
  /// line through a reference point is the chord to its nearer neighbour, or this smoothed normal
  /// where that chord is shorter than the baseline.
  double normal_baseline = 0.05;
};

/// @brief The reference side of PLICP: points in the reference frame, each linked to its
///        neighbours along its own scan, and a 2D kd-tree over them.
///
/// Built from one scan (consecutive matching) or from several scans with their poses in the
/// reference frame (a local map). Immutable after construction; matching against it is const
/// and thread-safe.
class PlicpReference {
 public:
  /// @brief An empty reference (matching against it returns Status::kInsufficientData).
  PlicpReference() = default;

  /// @brief Reference from one scan, in its own laser frame.
  explicit PlicpReference(const LaserScan& scan, const PlicpReferenceSettings& settings = {});

  /// @brief Reference from several scans; `T_ref_scans[k]` places scan k in the reference frame.
  /// @throws plumb::Error when the vectors differ in length.
  PlicpReference(const std::vector<const LaserScan*>& scans, const std::vector<Pose2>& T_ref_scans,
                 const PlicpReferenceSettings& settings = {});

  /// @brief Reference from ordered point chains (each inner vector is one scan's valid points in
  ///        beam order, already in the reference frame). Non-finite points are dropped.
  PlicpReference(const std::vector<std::vector<Vector2d>>& chains,
                 const PlicpReferenceSettings& settings = {});

  /// @brief Number of reference points.
  std::size_t size() const { return points_.size(); }
  bool empty() const { return points_.empty(); }
  /// @brief Point i in the reference frame [m].
  const Vector2d& point(std::size_t i) const { return points_[i]; }
  /// @brief Index of point i's previous / next neighbour along its scan, or -1.
  int prev(std::size_t i) const { return prev_[i]; }
  int next(std::size_t i) const { return next_[i]; }
  /// @brief Smoothed unit normal of point i (zero when its chain is too short to define one).
  const Vector2d& normal(std::size_t i) const { return normals_[i]; }
  /// @brief The chord length below which a point's smoothed normal defines its line [m]
  ///        (PlicpReferenceSettings::normal_baseline).
  double normal_baseline() const { return normal_baseline_; }
  /// @brief The kd-tree over the points (null when empty).
  const KdTree2f* tree() const { return tree_.empty() ? nullptr : &tree_.front(); }

 private:
  void add_chain(const std::vector<Vector2d>& chain, const Vector2d* origin, const PlicpReferenceSettings& settings);
  void build();

  std::vector<Vector2d> points_;
  std::vector<int> prev_, next_;
  std::vector<Vector2d> normals_;
  double normal_baseline_ = PlicpReferenceSettings{}.normal_baseline;
  std::vector<KdTree2f> tree_;  ///< zero or one tree (KdTree has no empty state)
};

/// @brief Settings of PLICP. Defaults suit indoor 180-360 beam scans at 0.1-1 m spacing.
struct PlicpSettings {
  int max_iterations = 40;              ///< N_max: correspondence/solve rounds
  double epsilon_xy = 1e-4;             ///< ζ: stop when the translation changes less [m] ...
  double epsilon_theta = 1e-4;          ///< ... and the rotation changes less [rad]
  double max_correspondence_distance = 0.5;  ///< distance gate to the nearest reference point [m]
  /// A pair is dropped when the current point's normal (from its scan neighbours) and the
  /// reference segment's normal differ by more than this [rad]; >= pi disables the check.
  double max_normal_angle = 0.6;
  /// Current-scan neighbours farther apart than this do not define a normal [m] ...
  double max_neighbor_distance = 0.5;
  /// ... unless closer than this many times range x angle between their beams (see
  /// PlicpReferenceSettings::grazing_factor). 0 = off.
  double grazing_factor = 3.0;
  /// A current point's normal is the chord to the nearest neighbours at least this far away on
  /// each side, which averages out range noise on dense scans [m]. Past the 16th neighbour the
  /// walk to them takes strides of 1/16 of the way walked, so the chord may reach ~6 % beyond
  /// the baseline and the cost grows with the log, not the number, of beams within it.
  double normal_baseline = 0.05;
  /// Trust region per round: when the exact solution of eq. 17 moves the estimate farther than
  /// this, a proximal term around the estimate is added (and grown) until the step fits [m] ...
  double max_step_xy = 0.3;
  double max_step_theta = 0.15;         ///< ... [rad]
  double trim_fraction = 0.9;           ///< keep this best fraction of the gated pairs, in (0, 1]
  /// Also drop pairs whose point-to-line distance exceeds this multiple of the trimmed pairs'
  /// median distance (adaptive outlier gate, CSM's "adaptive order"); <= 0 disables it.
  double outlier_median_factor = 0.0;
  /// Pairs with a point-to-line distance below this are never dropped by the adaptive gate [m].
  double outlier_min_distance = 0.02;
  std::size_t min_valid_pairs = 10;     ///< fewer valid pairs: Status::kInsufficientData
  /// Range noise used for the covariance when the residual is smaller [m] (keeps it honest
  /// for perfectly synthetic data).
  double sigma = 0.01;
  /// Degeneracy: the smallest eigenvalue of the normalized information matrix (see
  /// PlicpResult::min_normalized_eigenvalue) below this flags the match as degenerate.
  double degeneracy_threshold = 0.01;
};

/// @brief Outcome of one PLICP match.
struct PlicpResult {
  Pose2 T_ref_cur;              ///< pose of the current laser frame in the reference frame
  Status status = Status::kInvalidInput;  ///< kOk, kNotConverged, kInsufficientData, kInvalidInput
  bool converged = false;       ///< stopped on ζ before N_max
  int iterations = 0;           ///< rounds done
  std::size_t num_points = 0;   ///< valid points of the current scan
  std::size_t num_valid_pairs = 0;  ///< pairs kept (gated, trimmed) in the last round
  double valid_fraction = 0.0;  ///< num_valid_pairs / num_points
  double mse = 0.0;             ///< mean squared point-to-line distance of the kept pairs (eq. 18) [m^2]
  /// Covariance of (x, y, theta) from the Gauss-Newton Hessian of eq. 17 at the solution:
  /// s^2 (Σ J_i^T J_i)^-1 with s^2 = max(Σ e_i^2 / (n - 3), sigma^2) [m^2, m rad, rad^2].
  Matrix3d covariance = Matrix3d::Zero();
  /// Smallest eigenvalue of (1/n) D (Σ J_i^T J_i) D with D = diag(1, 1, 1/L), L the RMS range of
  /// the paired points: about 0.5 for a well-conditioned room, near 0 along a corridor.
  double min_normalized_eigenvalue = 0.0;
  /// Unit vector (x, y, L theta) of the weakest direction in the normalized coordinates.
  Vector3d weakest_direction = Vector3d::Zero();
  double characteristic_length = 1.0;  ///< L above [m]
  bool degenerate = false;      ///< min_normalized_eigenvalue < settings.degeneracy_threshold
};

/// @brief Match `current` against `reference`, starting from `T_ref_cur_guess`.
///
/// Each round (Liu et al. 2022, sec. 3.2): transform the current points with the estimate (eq. 16); pair each
/// with the nearest reference point j1 within the distance gate and, of j1's two scan neighbours,
/// the one nearer to the point (j2); drop the worst pairs (trim fraction, adaptive gate); solve
/// eq. 17 exactly (closed form, Lagrange multiplier on cos^2 + sin^2 = 1); stop when the change
/// of the estimate is below ζ or after N_max rounds.
/// Bad input never throws or crashes: an empty/all-invalid scan, an empty reference or a
/// non-finite guess give Status::kInvalidInput or kInsufficientData with the guess returned.
/// @note O(iterations · n log m); single-threaded, no allocation beyond O(n) scratch.
PlicpResult plicp(const LaserScan& current, const PlicpReference& reference,
                  const Pose2& T_ref_cur_guess, const PlicpSettings& settings = {});

/// @brief plicp() on points already converted from the current scan (laser frame).
PlicpResult plicp(const std::vector<Vector2d>& current_points, const PlicpReference& reference,
                  const Pose2& T_ref_cur_guess, const PlicpSettings& settings = {});

/// @brief Convenience: match two scans (builds the reference of `reference` each call).
PlicpResult plicp(const LaserScan& current, const LaserScan& reference, const Pose2& T_ref_cur_guess,
                  const PlicpSettings& settings = {});

/// @brief The laser's motion for a robot (base) motion: s = ⊖l ⊕ r ⊕ l (Liu et al. 2022, eq. 14), with
///        `T_base_laser` = l the laser's mounting pose on the robot.
inline Pose2 laser_motion(const Pose2& base_motion, const Pose2& T_base_laser) {
  return T_base_laser.ominus().oplus(base_motion).oplus(T_base_laser);
}

/// @brief One weighted point-to-line term of eq. 17: residual n^T (R(θ) p + t - q).
struct PointToLinePair {
  Vector2d p;       ///< current point, current frame [m]
  Vector2d q;       ///< a point on the reference line, reference frame [m]
  Vector2d normal;  ///< unit normal of the reference line
  double weight = 1.0;
};

/// @brief The exact minimiser of Σ w_i (n_i^T (R(θ) p_i + t - q_i))^2 over (t, θ)
///        (Liu et al. 2022, eq. 17).
/// @return false (and leaves `T` untouched) when the pairs do not constrain the pose (fewer than
///         three, or a singular translation block).
bool solve_point_to_line(const std::vector<PointToLinePair>& pairs, Pose2& T);

}  // namespace plumb
