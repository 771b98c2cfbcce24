// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// @brief Overlap-gated conditional-loop ICP (Liu et al. 2022, sec. 1.3), point-to-point (Horn) or
///        point-to-plane.

#include <cstddef>
#include <cstdint>
#include <vector>

#include <Eigen/Geometry>

#include "plumb/core/point_cloud.hpp"
#include "plumb/core/robust_kernel.hpp"
#include "plumb/core/status.hpp"
#include "plumb/search/kdtree.hpp"

namespace plumb {

/// @brief Error metric of align_icp().
enum class IcpMethod {
  kPointToPoint,  ///< Liu et al. 2022, eq. 3/7, solved in closed form by Horn's quaternion method (eq. 5-6)
  kPointToPlane,  ///< (n_q . (T p - q))^2, one linearised Gauss-Newton step per iteration; needs target normals
};

/// @brief Settings of align_icp(). Defaults suit metric indoor scans voxelised to ~0.1 m.
struct IcpSettings {
  IcpMethod method = IcpMethod::kPointToPoint;  ///< error metric
  double max_correspondence_distance = 1.0;     ///< d of the first round: pairs farther apart are ignored [m]
  double distance_step = 0.1;                   ///< Δd: d shrinks by this when the overlap gate fails [m]
  double min_correspondence_distance = 0.1;     ///< d never goes below this; reaching it ends the rounds [m]
  int max_rounds = 10;                          ///< most rounds (runs of steps 1-3 at one d), >= 1
  int max_iterations = 50;                      ///< N_max: iterations per round, >= 1
  /// tau: a round stops when the mean squared residual changes by less than this between two
  /// iterations, |d_k - d_{k+1}| < tau [m^2] (the criterion of Liu et al. 2022, sec. 1.3, with |.|
  /// so that a growing error does not count as convergence)
  double tolerance = 1e-7;
  double min_step = 1e-6;                 ///< a round also stops when an update moves less than this [m] / [rad]
  double min_overlap = 0.9;               ///< c: accepted when the overlap ratio is >= c, in [0, 1]
  double overlap_distance = 0.1;          ///< beta of the overlap ratio (Liu et al. 2022, sec. 1.3) [m]
  /// Pairs whose normals differ by more than this are rejected (Liu et al. 2022, sec. 1.3, ICP step
  /// (2)) [rad]; used only when both clouds have normals; the sign of a normal is ignored (scans and
  /// models orient differently).
  double max_normal_angle = 0.785398163397448;  // 45 deg
  RobustKernel kernel = RobustKernel::kNone;    ///< IRLS weights on the residuals
  double kernel_scale = 0.05;                   ///< scale of the robust kernel [m]
  std::size_t min_correspondences = 6;          ///< fewer pairs → Status::kInsufficientData
  /// smallest eigenvalue of the per-pair 6x6 normal matrix below which the result is
  /// Status::kDegenerate (0 disables the gate); see IcpResult::degeneracy
  double degeneracy_threshold = 0.0;
  /// Return the final correspondences in IcpResult::correspondences (for a caller that needs
  /// them, e.g. to build an information matrix, without searching the target again).
  bool keep_correspondences = false;
  /// Threads of the correspondence search (0 = every core). The result is bit-identical for any
  /// count (core/parallel.hpp): points are split into fixed chunks and summed in point order.
  int threads = 1;
};

/// @brief One final source-target pair of align_icp().
struct IcpCorrespondence {
  std::size_t source_index = 0;          ///< index in the source cloud
  std::size_t target_index = 0;          ///< index in the target cloud
  Eigen::Vector3d x = Eigen::Vector3d::Zero();  ///< the source point moved by T_target_source [m]
  Eigen::Vector3d q = Eigen::Vector3d::Zero();  ///< its nearest target point [m]
  Eigen::Vector3d n = Eigen::Vector3d::Zero();  ///< target normal at q (point-to-plane), else zero
};

/// @brief Result of align_icp().
struct IcpResult {
  Eigen::Isometry3d T_target_source = Eigen::Isometry3d::Identity();  ///< estimate (T_init when nothing was solved)
  Status status = Status::kInsufficientData;  ///< kOk: converged, overlap >= c, not degenerate
  bool converged = false;        ///< the last round met the stopping criterion (tau or min_step)
  int iterations = 0;            ///< iterations over all rounds
  int rounds = 0;                ///< rounds run (1 + times the overlap gate shrank d)
  std::size_t num_inliers = 0;   ///< correspondences at the final estimate within the final d
  double overlap = 0.0;          ///< overlap ratio at the final estimate (beta = overlap_distance), [0, 1]
  double rmse = 0.0;             ///< RMS residual of those correspondences (metric of `method`) [m]
  double final_correspondence_distance = 0.0;  ///< d of the last round [m]
  /// Degeneracy indicator: smallest eigenvalue of normal_matrix / num_inliers. Near 0 means a
  /// direction the geometry does not constrain (corridor, single plane).
  double degeneracy = 0.0;
  /// The 6x6 normal matrix J^T J of `method`'s residuals (point-to-plane: one per pair,
  /// n.(x - q); point-to-point: three, x - q) summed over the num_inliers final correspondences,
  /// J taken with respect to a small motion of the aligned source (rotation w, then translation
  /// v: x -> x + w x (x - normal_matrix_pivot) + v) in the target frame. Unweighted by the robust
  /// kernel and unscaled by the noise: times 1 / sigma^2 it is the information of the estimate
  /// for range noise sigma. Zero when there are no final correspondences.
  Matrix6d normal_matrix = Matrix6d::Zero();
  /// Centre of the rotation in normal_matrix: the centroid of the aligned source points of the
  /// final correspondences (target frame) [m].
  Vector3d normal_matrix_pivot = Vector3d::Zero();
  /// The num_inliers pairs at the final estimate, when settings.keep_correspondences (else empty).
  std::vector<IcpCorrespondence> correspondences;
};

/// @brief Align `source` to `target` from `T_init` (Liu et al. 2022, sec. 1.3): nearest neighbours within d,
///        normal-angle rejection, closed-form/linearised solve until |d_k - d_{k+1}| < tau or
///        N_max; then the overlap ratio; if it is below c, shrink d by Δd and run again.
/// @param target_tree kd-tree built on `target.points`
/// @throws plumb::Error for misuse: tree/cloud mismatch, bad settings, non-finite T_init,
///         point-to-plane without target normals, inconsistent cloud fields
/// @note Deterministic; single-threaded; O(iterations * n log m) at worst. Each source point keeps
///       its 8 nearest target points from its last kd-tree query (52 bytes per point); while it
///       has moved little since, they decide its nearest neighbour exactly without a new query, so
///       converging iterations cost O(n). The pairs equal plain nearest-neighbour queries, except
///       which of several target points at exactly the same float distance is paired.
IcpResult align_icp(const PointCloud& source, const PointCloud& target, const KdTree3f& target_tree,
                    const Eigen::Isometry3d& T_init, const IcpSettings& settings = {});

/// @brief align_icp() that builds the target kd-tree itself.
IcpResult align_icp(const PointCloud& source, const PointCloud& target,
                    const Eigen::Isometry3d& T_init, const IcpSettings& settings = {});

}  // namespace plumb
