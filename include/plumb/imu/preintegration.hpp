// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief On-manifold IMU preintegration (Forster et al., T-RO 2017; Zhou et al. 2021, eq. 13-18) and the
///        IMU factor between two navigation states, with analytic Jacobians for an estimator.
///
/// Conventions
/// - State `ImuState{R_world_body, p_world_body, v_world, bias}`; tangent (error) order
///   `[dphi, dp, dv, dbg, dba]` (ImuTangent indices), perturbed as
///   `R exp(dphi)`, `p + dp`, `v + dv`, `b + db` (right perturbation on SO(3), world-frame vectors).
/// - Preintegrated error order `[dphi, dp, dv]` (9) and `[dphi, dp, dv, dbg, dba]` (15): the same
///   order as the factor residual, so covariance_with_bias() is the residual's covariance.
/// - Between samples the measurements are held constant (zero-order hold, Zhou et al. 2021,
///   eq. 13-15) and the hold interval is integrated exactly: dR = exp(w dt), dv = R Gamma1(w dt) a dt,
///   dp = R Gamma2(w dt) a dt^2 with Gamma1 = J_l, Gamma2 = sum_n hat(phi)^n / (n+2)!. Forster's
///   scheme is the first-order truncation (Gamma1 ~ I, Gamma2 ~ I/2); the exact one makes constant-rate
///   motions (circles at constant speed) exact to rounding, and bias Jacobians and covariance below
///   are the exact derivatives of this scheme.

#include <cstddef>
#include <vector>

#include <Eigen/Core>

#include "plumb/core/lie.hpp"
#include "plumb/core/status.hpp"
#include "plumb/core/types.hpp"
#include "plumb/imu/imu.hpp"

namespace plumb {

using Vector9d = Eigen::Matrix<double, 9, 1>;
using Matrix9d = Eigen::Matrix<double, 9, 9>;
using Vector15d = Eigen::Matrix<double, 15, 1>;
using Matrix15d = Eigen::Matrix<double, 15, 15>;

/// @brief Offsets of the blocks in the 15-dimensional IMU state tangent, residual and covariance.
struct ImuTangent {
  static constexpr int kR = 0;    ///< rotation dphi (right perturbation) [rad]
  static constexpr int kP = 3;    ///< position dp, world frame [m]
  static constexpr int kV = 6;    ///< velocity dv, world frame [m/s]
  static constexpr int kBg = 9;   ///< gyro bias [rad/s]
  static constexpr int kBa = 12;  ///< accel bias [m/s^2]
  static constexpr int kDim = 15;
};

/// @brief Navigation state of the IMU (body) frame plus its biases, as the estimator sees it.
struct ImuState {
  Matrix3d R_world_body = Matrix3d::Identity();  ///< orientation
  Vector3d p_world_body = Vector3d::Zero();      ///< body origin in the world [m]
  Vector3d v_world = Vector3d::Zero();           ///< velocity of the body origin, world frame [m/s]
  ImuBias bias;                                  ///< biases, held constant between i and j
};

/// @brief x (+) delta: `R exp(dphi)`, `p + dp`, `v + dv`, `b + db` (ImuTangent order).
ImuState retract(const ImuState& x, const Vector15d& delta);

/// @brief Settings of ImuPreintegration.
struct PreintegrationSettings {
  ImuNoise noise;                       ///< noise densities for the covariance (MEMS defaults)
  Vector3d g_world = gravity_z_up();    ///< gravity in the world frame [m/s^2], z up by default
  double max_gap = 0.05;                ///< longest accepted time without a sample in integrate() [s]
};

/// @brief The IMU factor of an estimator: residual between two states and its Jacobians.
struct ImuFactorResidual {
  Vector15d r = Vector15d::Zero();     ///< [r_R, r_p, r_v, r_bg, r_ba] (Forster eq. 45 + bias walk)
  Matrix15d J_r_xi_i = Matrix15d::Zero();  ///< d r / d (tangent of state i), ImuTangent order
  Matrix15d J_r_xi_j = Matrix15d::Zero();  ///< d r / d (tangent of state j), ImuTangent order
};

/// @brief Preintegrated IMU measurements between two times i and j (Forster 2017, sec. V-VI).
///
/// Accumulates delta_R_ij, delta_v_ij, delta_p_ij (body frame i, gravity-free) for a fixed
/// linearisation bias `bias_hat`, their Jacobians w.r.t. the biases, the covariance of the
/// preintegration error with biases known (9x9) and with the bias random walk (15x15).
/// Typical use: one object per LiDAR frame interval, `integrate(imu, t_i, t_j)`, then
/// `predict(state_i)` for the initial guess and `residual(state_i, state_j)` inside the solver;
/// when the bias estimate moves far from `bias_hat`, `reset(new_bias)` and integrate again.
/// @note Not thread-safe for concurrent writes; const member functions may be called concurrently.
class ImuPreintegration {
 public:
  /// @brief Empty preintegration (delta_t 0, identity deltas) at linearisation bias `bias_hat`.
  explicit ImuPreintegration(const ImuBias& bias_hat = {}, const PreintegrationSettings& settings = {});

  /// @brief Drop everything integrated so far and restart at the bias `bias_hat`.
  void reset(const ImuBias& bias_hat);

  /// @brief Add one hold interval: `gyro`, `accel` measured and held constant for `dt`.
  /// @throws plumb::Error when dt is not positive and finite or a measurement is not finite.
  void add_measurement(const Vector3d& gyro, const Vector3d& accel, double dt);

  /// @brief Integrate `samples` (sorted by stamp, as read from the IMU) over [t0, t1], appending
  ///        to what is already integrated. The measurement at t0 is interpolated linearly between
  ///        the samples around it; each sample is then held until the next one (or t1).
  /// @return kOk; kInsufficientData when the samples do not cover [t0, t1] (a sample within max_gap
  ///         of an end is held up to it) or two consecutive samples are more than max_gap apart;
  ///         kInvalidInput when a stamp in the span does not increase or a value is not finite.
  ///         On any status but kOk nothing is integrated (the object is unchanged).
  /// @note Integrating [t0, t1] then [t1, t2] uses the value interpolated at t1 for the rest of that
  ///       sample interval, so it differs (by the change between two samples) from [t0, t2] at once.
  /// @throws plumb::Error when t0 or t1 is not finite or t1 < t0 (the caller's mistake).
  /// @note O(log n + m) for n samples, m of them in the span.
  Status integrate(const std::vector<ImuSample>& samples, double t0, double t1);

  const PreintegrationSettings& settings() const { return settings_; }
  const ImuBias& bias_hat() const { return bias_hat_; }  ///< linearisation bias
  double delta_t() const { return delta_t_; }            ///< integrated time Delta t_ij [s]
  std::size_t num_measurements() const { return num_measurements_; }  ///< hold intervals added

  const Matrix3d& delta_R_ij() const { return delta_R_; }  ///< Delta R_ij at bias_hat (eq. 35)
  const Vector3d& delta_v_ij() const { return delta_v_; }  ///< Delta v_ij at bias_hat [m/s]
  const Vector3d& delta_p_ij() const { return delta_p_; }  ///< Delta p_ij at bias_hat [m]

  const Matrix3d& J_R_bg() const { return J_R_bg_; }  ///< d Delta R_ij / d b_g (right perturbation)
  const Matrix3d& J_v_bg() const { return J_v_bg_; }  ///< d Delta v_ij / d b_g
  const Matrix3d& J_v_ba() const { return J_v_ba_; }  ///< d Delta v_ij / d b_a
  const Matrix3d& J_p_bg() const { return J_p_bg_; }  ///< d Delta p_ij / d b_g
  const Matrix3d& J_p_ba() const { return J_p_ba_; }  ///< d Delta p_ij / d b_a

  /// @brief Covariance of the preintegration error [dphi, dp, dv] with the biases known (eq. 63).
  const Matrix9d& covariance() const { return cov9_; }
  /// @brief Covariance of the IMU factor residual [r_R, r_p, r_v, r_bg, r_ba] at the true states:
  ///        white noise and the bias random walk within the interval propagated together (their
  ///        effects are correlated: the walk b(t) - b_i is not removed by the correction at b_i).
  const Matrix15d& covariance_with_bias() const { return cov15_; }
  /// @brief Upper-triangular U with U^T U = covariance_with_bias()^-1: whitened residual = U r.
  /// @throws plumb::Error when the covariance is not positive definite (zero noise, nothing integrated).
  Matrix15d sqrt_information_with_bias() const;

  /// @brief First-order bias update (Forster eq. 44): Delta R_ij exp(J_R_bg (b_g - bhat_g)).
  Matrix3d delta_R_ij_corrected(const ImuBias& bias) const;
  /// @brief Delta v_ij + J_v_bg (b_g - bhat_g) + J_v_ba (b_a - bhat_a).
  Vector3d delta_v_ij_corrected(const ImuBias& bias) const;
  /// @brief Delta p_ij + J_p_bg (b_g - bhat_g) + J_p_ba (b_a - bhat_a).
  Vector3d delta_p_ij_corrected(const ImuBias& bias) const;

  /// @brief State j from state i (Forster eq. 38 with the bias-corrected deltas at state_i.bias):
  ///        R_j = R_i dR, v_j = v_i + g dt + R_i dv, p_j = p_i + v_i dt + g dt^2/2 + R_i dp, b_j = b_i.
  ImuState predict(const ImuState& state_i) const;

  /// @brief IMU factor residual (Forster eq. 45, deltas corrected at state_i.bias, plus the bias
  ///        random walk b_j - b_i) and its analytic Jacobians w.r.t. both states.
  ImuFactorResidual residual(const ImuState& state_i, const ImuState& state_j) const;

 private:
  PreintegrationSettings settings_;
  ImuBias bias_hat_;
  double delta_t_ = 0.0;
  std::size_t num_measurements_ = 0;
  Matrix3d delta_R_ = Matrix3d::Identity();
  Vector3d delta_v_ = Vector3d::Zero();
  Vector3d delta_p_ = Vector3d::Zero();
  Matrix3d J_R_bg_ = Matrix3d::Zero();
  Matrix3d J_v_bg_ = Matrix3d::Zero();
  Matrix3d J_v_ba_ = Matrix3d::Zero();
  Matrix3d J_p_bg_ = Matrix3d::Zero();
  Matrix3d J_p_ba_ = Matrix3d::Zero();
  Matrix9d cov9_ = Matrix9d::Zero();
  Matrix15d cov15_ = Matrix15d::Zero();
};

}  // namespace plumb
