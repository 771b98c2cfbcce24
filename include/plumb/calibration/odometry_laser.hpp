// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Simultaneous calibration of a differential-drive robot's odometry (wheel radii, axle) and
///        of a 2D laser's mounting pose from scan-matcher motions (Liu et al. 2022, sec. 3.1; Censi, Franchi,
///        Marchionni, Oriolo, "Simultaneous calibration of odometry and sensor parameters for
///        mobile robots", IEEE T-RO 2013).
///
/// Model (Liu et al. 2022, eq. 13-14). Over an interval of length T with constant wheel angular velocities
/// φ_L, φ_R the robot moves by the arc
///   v = r_L/2 φ_L + r_R/2 φ_R,   ω = (-r_L φ_L + r_R φ_R) / b,
///   r = (v T sin(ωT)/(ωT),  v T (1 - cos(ωT))/(ωT),  ωT),
/// and the laser, mounted at l = (l_x, l_y, l_θ) on the robot, sees the motion s = ⊖l ⊕ r ⊕ l.
/// Given tuples (T, φ_L, φ_R, ŝ), the method estimates the six parameters in two linear steps:
///   1. the rotation part ŝ_θ = T (J21 φ_L + J22 φ_R) with J21 = -r_L/b, J22 = r_R/b is linear:
///      J21, J22 by least squares;
///   2. with J21, J22 fixed, the translation part of r ⊕ l = l ⊕ ŝ is linear in
///      x = (b, l_x, l_y, cos l_θ, sin l_θ); minimise xᵀ M x subject to x_4² + x_5² = 1. The
///      Lagrange condition (M + λW) x = 0, W = diag(0, 0, 0, 1, 1), makes det(M + λW) = 0 a
///      quadratic in λ; its larger root gives the constrained minimum. Then r_L = -b J21,
///      r_R = b J22, l_θ = atan2(x_5, x_4).
/// Outliers are rejected as in Censi's solver: after each solve, the tuples whose residual
/// (l ⊕ ŝ) - (r ⊕ l) exceeds the given quantile in translation norm or in |angle| are dropped, and
/// the problem is solved again. The covariance is the inverse Fisher information
/// Σ_k J_kᵀ Σ_s⁻¹ J_k, with J_k = ∂ŝ_k/∂(r_L, r_R, b, l_x, l_y, l_θ) and the scan-matcher noise
/// Σ_s = diag(σ_x², σ_y², σ_θ²) estimated from the residuals ŝ_k - s_k(params).

#include <cstddef>
#include <vector>

#include "plumb/core/pose2.hpp"
#include "plumb/core/sensor_data.hpp"
#include "plumb/core/status.hpp"
#include "plumb/core/types.hpp"

namespace plumb {

/// @brief The six parameters: differential-drive kinematics and the laser's pose on the robot.
struct OdometryLaserParams {
  double radius_left = 0.0;   ///< r_L, left wheel radius [m]
  double radius_right = 0.0;  ///< r_R, right wheel radius [m]
  double axle = 0.0;          ///< b, distance between the wheels [m]
  Pose2 laser;                ///< l = (l_x, l_y, l_θ): laser pose in the robot frame [m, rad]

  /// @brief The parameters as a vector in the covariance order (r_L, r_R, b, l_x, l_y, l_θ).
  Vector6d vector() const {
    Vector6d v;
    v << radius_left, radius_right, axle, laser.x, laser.y, laser.theta;
    return v;
  }
  /// @brief Inverse of vector().
  static OdometryLaserParams from_vector(const Vector6d& v) {
    return {v(0), v(1), v(2), Pose2{v(3), v(4), v(5)}};
  }
};

/// @brief Robot motion r over an interval of T seconds with constant wheel angular velocities
///        (exact arc of the differential-drive kinematics; see the file comment).
Pose2 differential_drive_motion(double radius_left, double radius_right, double axle, double T,
                                double phi_left, double phi_right);

/// @brief The laser motion the model predicts for a tuple: s = ⊖l ⊕ r(T, φ_L, φ_R) ⊕ l
///        (Liu et al. 2022, eq. 14).
Pose2 predicted_laser_motion(const OdometryLaserParams& params, const CalibrationTuple& tuple);

/// @brief Settings of calibrate_odometry_laser(). Defaults are those of Censi's published runs
///        (`solver_options=-mode 0 -outliers_iterations 4`).
struct OdometryLaserCalibrationSettings {
  /// Rounds of outlier rejection; the estimate is solved outlier_iterations + 1 times.
  int outlier_iterations = 4;
  /// Per round, tuples whose translation residual norm or |angle residual| is above this quantile
  /// of the current tuples' residuals are dropped (so about 1 - quantile of them per round).
  double outlier_quantile = 0.99;
  /// Step 1 (J21, J22) is refused with kDegenerate when the 2x2 normal matrix Σ L_kᵀ L_k,
  /// L_k = T (φ_L, φ_R), has a larger condition number (ratio of eigenvalues): only straight
  /// driving or only turning on the spot. Censi's solver uses 75.
  double max_condition_number = 75.0;
  /// Step 2 is refused with kDegenerate when the 3x3 block of M for (b, l_x, l_y), scaled to unit
  /// diagonal, has a smaller eigenvalue than this (laser position or axle unobservable).
  double min_scaled_eigenvalue = 1e-9;
  /// Minimum number of tuples, before and after outlier rejection (at least the 6 unknowns).
  std::size_t min_tuples = 6;
  /// The scan-matcher noise is estimated from the residuals of the tuples kept after this many
  /// rejection rounds (clamped to outlier_iterations), evaluated at the final estimate. Censi's
  /// solver uses 1: later rounds trim the residual tails and would understate the noise.
  int noise_estimate_round = 1;
};

/// @brief Outcome of calibrate_odometry_laser().
struct OdometryLaserCalibrationResult {
  /// kOk; kInsufficientData (too few tuples); kDegenerate (motion does not excite every
  /// parameter, or a non-positive axle / radius came out). When not kOk, params and covariance
  /// are zero (never NaN).
  Status status = Status::kInsufficientData;
  OdometryLaserParams params;  ///< the estimate
  /// Covariance of (r_L, r_R, b, l_x, l_y, l_θ) [m², rad²], the inverse Fisher information.
  Matrix6d covariance = Matrix6d::Zero();
  double j21 = 0.0;  ///< J21 = -r_L / b from step 1 of the last solve [rad/rad]
  double j22 = 0.0;  ///< J22 = r_R / b from step 1 of the last solve [rad/rad]
  Vector3d laser_noise_std = Vector3d::Zero();  ///< estimated σ of ŝ (x [m], y [m], θ [rad])
  std::size_t num_tuples = 0;   ///< tuples given
  std::size_t num_inliers = 0;  ///< tuples used by the last solve
  std::vector<bool> inlier;     ///< per input tuple: used by the last solve
  int solves = 0;               ///< how many times the two-step estimate was solved
  double condition_number = 0.0;  ///< of the step-1 normal matrix in the last solve
};

/// @brief Estimate wheel radii, axle and laser pose from calibration tuples (see the file comment).
/// @param tuples intervals with wheel speeds and scan-matcher laser motions
/// @throws plumb::Error if a tuple has T <= 0 or a non-finite field (the index is named).
/// @note Deterministic; O(n log n) per rejection round (sorting the residuals).
OdometryLaserCalibrationResult calibrate_odometry_laser(
    const std::vector<CalibrationTuple>& tuples, const OdometryLaserCalibrationSettings& settings = {});

/// @brief Fisher information of the six parameters from the given tuples, with scan-matcher noise
///        σ = laser_noise_std (all > 0): Σ_k J_kᵀ diag(σ)⁻² J_k, J_k = ∂s_k/∂params (central
///        differences). Exposed for tests and for planning experiments (which motions inform what).
Matrix6d odometry_laser_information(const std::vector<CalibrationTuple>& tuples,
                                    const OdometryLaserParams& params,
                                    const Vector3d& laser_noise_std);

}  // namespace plumb
