// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// @brief The Levenberg-Marquardt step of every estimator of plumb that minimises a least-squares
///        cost on a manifold: LOAM odometry, HybridLio's joint IMU + LiDAR problem and the general
///        solver of `optim` (solve_least_squares) all take their steps through LevenbergMarquardt.
///
/// Each of them linearises its cost at the current estimate (re-associating first, for the scan
/// matchers) into the Gauss-Newton system H delta = -g, then asks for one accepted step:
/// @code
///   LevenbergMarquardt lm;                      // damping state, kept across linearisations
///   Vector6d delta;
///   const bool accepted = lm.step(H, g, cost, [&](const Vector6d& d) { return cost_at(T * se3::exp(d)); }, delta);
///   if (accepted) T = T * se3::exp(delta);
/// @endcode
/// The step rule (Marquardt's scaling): solve (H + lambda diag(max(H_dd, 1e-9))) delta = -g by LDLT;
/// a step whose cost is not above the current cost is accepted and lambda shrinks tenfold (not below
/// 1e-12); otherwise lambda grows tenfold (within [1e-8, max_lambda]) and the step is tried again,
/// at most `max_attempts` times. Scaling by the diagonal makes the damping invariant to the units
/// of each unknown (radians beside metres); the floor keeps a direction without information damped.

#include <algorithm>

#include <Eigen/Cholesky>

#include "plumb/core/error.hpp"

namespace plumb {

/// @brief Settings of LevenbergMarquardt.
struct LevenbergMarquardtSettings {
  double initial_lambda = 1e-4;  ///< damping at the first step, relative to diag(H)
  double max_lambda = 1e12;      ///< the damping never grows beyond this
  int max_attempts = 10;         ///< tries per step (each a solve and a cost evaluation)
};

/// @brief Damping state of a Levenberg-Marquardt solver, carried from one step to the next.
/// @note Deterministic; one instance per solve.
class LevenbergMarquardt {
 public:
  /// @throws plumb::Error unless 0 <= initial_lambda <= max_lambda (finite) and max_attempts >= 1.
  explicit LevenbergMarquardt(const LevenbergMarquardtSettings& settings = {})
      : settings_(settings), lambda_(settings.initial_lambda) {
    PLUMB_CHECK(settings.initial_lambda >= 0.0 && settings.initial_lambda <= settings.max_lambda &&
                    settings.max_lambda < 1e300,
                "LevenbergMarquardt: need 0 <= initial_lambda <= max_lambda (finite), got "
                    << settings.initial_lambda << " and " << settings.max_lambda);
    PLUMB_CHECK(settings.max_attempts >= 1, "LevenbergMarquardt: max_attempts must be >= 1, got "
                                                << settings.max_attempts);
  }

  /// @brief Find a step from the Gauss-Newton system (H, g) at a point of cost `cost`.
  /// @param H, g         the system H delta = -g (H symmetric positive semi-definite), fixed-size or dynamic
  /// @param cost         the cost at the current point
  /// @param cost_of      `double(const Vector& delta)`: the cost at the point moved by delta
  /// @param[out] delta   the accepted step (when the result is true), else the last one tried
  /// @return true when a step did not raise the cost; false when none of the attempts found one or
  ///         a solve was not finite (then the current point is where to stop).
  template <typename Matrix, typename Vector, typename CostOf>
  bool step(const Matrix& H, const Vector& g, double cost, CostOf&& cost_of, Vector& delta) {
    for (int attempt = 0; attempt < settings_.max_attempts; ++attempt) {
      Matrix A = H;
      for (Eigen::Index d = 0; d < A.rows(); ++d) A(d, d) += lambda_ * std::max(A(d, d), 1e-9);
      delta = A.ldlt().solve(-g);
      if (!delta.allFinite()) return false;
      if (cost_of(static_cast<const Vector&>(delta)) <= cost) {
        lambda_ = std::max(lambda_ * 0.1, 1e-12);
        return true;
      }
      lambda_ = std::min(std::max(lambda_ * 10.0, 1e-8), settings_.max_lambda);
      ++num_rejected_;
    }
    return false;
  }

  /// @brief The damping the next step starts with.
  double lambda() const { return lambda_; }
  /// @brief Attempts so far whose step raised the cost.
  int num_rejected() const { return num_rejected_; }
  /// @brief True when the damping has reached max_lambda (a further rejected step cannot grow it).
  bool at_max_lambda() const { return lambda_ >= settings_.max_lambda; }

 private:
  LevenbergMarquardtSettings settings_;
  double lambda_;
  int num_rejected_ = 0;
};

}  // namespace plumb
