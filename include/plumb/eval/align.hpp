// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Least-squares alignment of an estimated trajectory to a reference (Umeyama 1991).

#include <vector>

#include <Eigen/Geometry>

#include "plumb/core/status.hpp"
#include "plumb/core/trajectory.hpp"
#include "plumb/core/types.hpp"

namespace plumb::eval {

/// @brief Which similarity to fit between estimate and reference.
enum class AlignMode {
  kNone,  ///< identity
  kSE3,   ///< rotation + translation
  kSim3,  ///< rotation + translation + uniform scale
};

/// @brief Stable lower-case name ("none", "se3", "sim3").
const char* to_string(AlignMode mode);

/// @brief The similarity `p_ref ≈ scale * R * p_est + t`, stored as an isometry plus a scale.
struct UmeyamaResult {
  Eigen::Isometry3d T_ref_est = Eigen::Isometry3d::Identity();  ///< rotation R and translation t
  double scale = 1.0;                                           ///< 1 unless with_scale
  double rmse = 0.0;  ///< residual sqrt(mean |p_ref - (s R p_est + t)|^2) [m]
  /// kOk; kDegenerate when the points are (nearly) collinear, so the rotation about their line is
  /// not determined (a valid rotation is still returned); kInsufficientData for fewer than 2 points.
  Status status = Status::kOk;
};

/// @brief Umeyama's closed form (IEEE PAMI 13(4), 1991, eqs. 34-42): the rotation, translation and
///        optionally scale minimising sum |target_i - (s R source_i + t)|^2.
/// @note Uses the sign correction of eq. 39/43 so that R is a rotation (det +1), never a reflection.
///       O(n); deterministic.
/// @throws plumb::Error when the point sets are empty or differ in size.
UmeyamaResult umeyama(const std::vector<Vector3d>& source, const std::vector<Vector3d>& target,
                      bool with_scale);

/// @brief Positions (translation parts) of a trajectory's poses.
std::vector<Vector3d> positions(const Trajectory& trajectory);

/// @brief Apply a similarity to every pose: positions become `s R p + t`, orientations `R R_p`
///        (scale the translations, then left-multiply by T_ref_est, as evo does).
Trajectory apply_similarity(const Trajectory& trajectory, const Eigen::Isometry3d& T_ref_est,
                            double scale);

/// @brief An estimate aligned to its reference and the similarity used.
struct AlignResult {
  Trajectory aligned;       ///< the estimate mapped into the reference frame
  UmeyamaResult transform;  ///< identity for AlignMode::kNone
};

/// @brief Fit `mode` between the positions of `estimate` and `reference` (already associated, same
///        size, pose i with pose i) and apply it to the estimate.
/// @throws plumb::Error when the sizes differ or the trajectories are empty.
AlignResult align_trajectory(const Trajectory& estimate, const Trajectory& reference, AlignMode mode);

}  // namespace plumb::eval
