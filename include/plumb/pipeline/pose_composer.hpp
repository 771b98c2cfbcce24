// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief The pose composer of the BIM-corrected odometry (Liu et al. 2022, sec. 3.3, loop step (5)):
///        chains the front end's relative motions and applies absolute corrections from the BIM.
///
/// State: the current base (body) pose in the world (BIM) frame, `T_world_base`, and its 6x6 covariance
/// P in the world frame, with left perturbations `T_true = exp(δ) · T` (δ = [ρ; φ], plumb/core/lie.hpp).
///
/// - add_motion(T_prev_cur, Q): `T ← T · T_prev_cur`; the motion's covariance Q is in the body frame
///   (right perturbation, as a scan matcher reports it) and is moved to the world frame:
///   `P ← P + Ad(T) Q Ad(T)ᵀ`. Without anchors this is plain odometry, exactly the chained product.
/// - add_anchor(T_meas, Λ): an absolute measurement of the current pose (e.g. key points registered to
///   the BIM cloud) with information Λ in the world frame. Λ may be singular: a corridor constrains no
///   motion along its axis, and that direction then stays uncorrected. The innovation
///   `e = log(T_meas · T⁻¹)` is gated by its Mahalanobis distance `d² = eᵀ S⁻¹ e`,
///   `S⁻¹ = Λ − Λ (P⁻¹ + Λ)⁻¹ Λ`, against the χ² quantile for rank(Λ) degrees of freedom; an accepted
///   anchor moves the pose by `δ = (P⁻¹ + Λ)⁻¹ Λ e`, `T ← exp(δ) · T`, and `P ← (P⁻¹ + Λ)⁻¹`. With
///   Λ → ∞ this is the `M ← M_e · M` of Liu et al. 2022, sec. 3.3, with `M_e = T_meas · T⁻¹`.
/// - After `max_consecutive_rejections` rejected anchors in a row the composer assumes its own
///   covariance is too small (e.g. wheel slip the motion model did not foresee), inflates P by the
///   last innovation and accepts the next anchor that passes the inflated gate.
///
/// The composer is causal (a robot's online estimate): corrections act on the current and later poses,
/// past poses stay as they were reported.

#include <cstddef>
#include <vector>

#include <Eigen/Geometry>

#include "plumb/core/trajectory.hpp"
#include "plumb/core/types.hpp"

namespace plumb {

/// @brief Settings of PoseComposer.
struct PoseComposerSettings {
  /// Probability of the χ² gate on anchors (0, 1); 0.999 rejects a consistent anchor once in 1000.
  double gate_probability = 0.999;
  /// Rejected anchors in a row after which P is inflated (0 = never).
  std::size_t max_consecutive_rejections = 5;
  /// Eigenvalues of Λ below this fraction of its largest count as zero (unconstrained directions).
  double rank_tolerance = 1e-9;
};

/// @brief What add_anchor() did.
enum class AnchorDecision {
  kAccepted,  ///< passed the gate; the pose was corrected
  kRejected,  ///< failed the Mahalanobis gate; the pose is unchanged
  kIgnored,   ///< Λ is zero: nothing to correct
};

/// @brief Stable lower-case name ("accepted", "rejected", "ignored").
const char* to_string(AnchorDecision d);

/// @brief Result of add_anchor().
struct AnchorResult {
  AnchorDecision decision = AnchorDecision::kIgnored;
  double mahalanobis_sq = 0.0;  ///< d² of the innovation
  double gate = 0.0;            ///< χ² quantile it was compared with
  int dof = 0;                  ///< rank of Λ
  Vector6d innovation = Vector6d::Zero();  ///< e = log(T_meas T⁻¹) before the update, world frame
  Vector6d correction = Vector6d::Zero();  ///< δ applied (zero unless accepted)
  bool inflated = false;        ///< P was inflated after too many rejections before this anchor
};

/// @brief Chains relative motions and fuses absolute anchors (see the file comment).
class PoseComposer {
 public:
  /// @param T_world_base0 initial pose (e.g. the BimLocalizer's result)
  /// @param P0 its covariance, world frame, symmetric positive definite
  /// @throws plumb::Error for a non-finite pose or a P0 that is not symmetric positive definite
  PoseComposer(const Eigen::Isometry3d& T_world_base0, const Matrix6d& P0,
               const PoseComposerSettings& settings = {});

  /// @brief Chain a relative motion T_prev_cur with body-frame covariance Q (symmetric PSD).
  /// @throws plumb::Error for non-finite input or a Q that is not symmetric PSD
  void add_motion(const Eigen::Isometry3d& T_prev_cur, const Matrix6d& Q);

  /// @brief Fuse an absolute measurement of the current pose (information Λ, world frame, PSD).
  /// @throws plumb::Error for non-finite input or a Λ that is not symmetric PSD
  AnchorResult add_anchor(const Eigen::Isometry3d& T_world_base_measured, const Matrix6d& information);

  /// @brief The form of Liu et al. 2022, sec. 3.3: the correction M_e (T_meas = M_e · T) with
  ///        information Λ.
  AnchorResult add_correction(const Eigen::Isometry3d& M_e, const Matrix6d& information) {
    return add_anchor(M_e * pose_, information);
  }

  const Eigen::Isometry3d& pose() const { return pose_; }  ///< current T_world_base
  const Matrix6d& covariance() const { return P_; }       ///< current P, world frame
  std::size_t num_accepted() const { return num_accepted_; }
  std::size_t num_rejected() const { return num_rejected_; }
  const PoseComposerSettings& settings() const { return settings_; }

 private:
  PoseComposerSettings settings_;
  Eigen::Isometry3d pose_;
  Matrix6d P_;
  std::size_t num_accepted_ = 0, num_rejected_ = 0, consecutive_rejections_ = 0;
  Vector6d last_rejected_innovation_ = Vector6d::Zero();
};

/// @brief Information of a pose measurement whose error is given in the body frame
///        (`T_meas = T · exp(ε)`, ε with information Λ_body) expressed for the world-frame left
///        perturbation PoseComposer uses: `Λ_world = Ad(T)⁻ᵀ Λ_body Ad(T)⁻¹`.
Matrix6d body_to_world_information(const Eigen::Isometry3d& T_world_body, const Matrix6d& information_body);

/// @brief Quantile of the χ² distribution with `dof` degrees of freedom (dof >= 1, 0 < p < 1).
double chi_square_quantile(double p, int dof);

/// @brief A 6x6 body-frame covariance from a planar (x, y, θ) covariance, with small independent
///        variances for z, roll and pitch (a robot on a floor). Order [x y z roll pitch yaw] =
///        the [ρ; φ] order of lie.hpp.
Matrix6d planar_covariance(const Matrix3d& cov_xy_theta, double var_z = 1e-6, double var_roll_pitch = 1e-6);

}  // namespace plumb
