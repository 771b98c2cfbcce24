// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// @brief Robust kernels (M-estimators): the loss and IRLS weight of a residual, for every estimator
///        of plumb (ICP, the SAC-IA score, LOAM odometry, HybridLio's joint problem, the least-squares
///        solver).
///
/// A kernel comes in two parametrisations, which agree in exact arithmetic:
/// - of a residual r (a scalar, or the norm of a residual block): `loss(r)` = rho(r) with
///   rho(r) = r^2 / 2 inside the scale, and the IRLS weight `weight(r)` = rho'(r) / r;
/// - of a squared norm s = |r|^2 (the convention of the least-squares solver, cost 1/2 sum rho(s)):
///   `rho(s)` = s inside the scale, and the IRLS weight `rho_prime(s)` = d rho / d s.
///
/// rho(r^2) = 2 loss(r) and rho_prime(r^2) = weight(r); in floating point the two forms round
/// differently, so an estimator uses the form its cost is written in.

#include <cmath>

#include "plumb/core/error.hpp"

namespace plumb {

/// @brief Kind of robust kernel; d is the scale of RobustLoss.
enum class RobustKernel {
  kNone,    ///< plain least squares: loss r^2 / 2, weight 1
  kHuber,   ///< quadratic inside d, linear beyond: loss d (|r| - d / 2), weight d / |r| (Liu et al. 2022, eq. 2)
  kCauchy,  ///< loss d^2 / 2 log(1 + (r/d)^2), weight 1 / (1 + (r/d)^2): far outliers have a vanishing influence
  kTukey,   ///< biweight: loss d^2 / 6 (1 - (1 - (r/d)^2)^3), weight (1 - (r/d)^2)^2; constant loss, zero weight
            ///< beyond d
};

/// @brief A robust kernel with its scale d (in the residual's units, e.g. [m], or [sigmas] for a
///        whitened residual).
/// @note Every kernel has weight 1 at r = 0 and weights in [0, 1]; losses never exceed the quadratic.
struct RobustLoss {
  RobustKernel kernel = RobustKernel::kNone;  ///< kind of kernel
  double scale = 1.0;                         ///< d > 0: residual (norm) where the loss leaves the quadratic

  /// @brief Plain least squares (kNone).
  static RobustLoss none() { return {}; }
  /// @throws plumb::Error when scale is not positive and finite.
  static RobustLoss huber(double scale) { return make(RobustKernel::kHuber, scale); }
  /// @throws plumb::Error when scale is not positive and finite.
  static RobustLoss cauchy(double scale) { return make(RobustKernel::kCauchy, scale); }
  /// @throws plumb::Error when scale is not positive and finite.
  static RobustLoss tukey(double scale) { return make(RobustKernel::kTukey, scale); }
  /// @brief A kernel of any kind with its scale.
  /// @throws plumb::Error when scale is not positive and finite.
  static RobustLoss make(RobustKernel kernel, double scale) {
    PLUMB_CHECK(scale > 0.0 && std::isfinite(scale), "RobustLoss: scale must be positive, got " << scale);
    RobustLoss l;
    l.kernel = kernel;
    l.scale = scale;
    return l;
  }

  /// @brief rho(r) of a residual r (sign ignored): r^2 / 2 for kNone, and for kHuber up to |r| = d.
  double loss(double r) const {
    const double a = std::abs(r);
    switch (kernel) {
      case RobustKernel::kNone: return 0.5 * a * a;
      case RobustKernel::kHuber: return a <= scale ? 0.5 * a * a : scale * (a - 0.5 * scale);
      case RobustKernel::kCauchy: {
        const double u = a / scale;
        return 0.5 * scale * scale * std::log1p(u * u);
      }
      case RobustKernel::kTukey: {
        const double d2_6 = scale * scale / 6.0;
        if (a >= scale) return d2_6;
        const double u = a / scale;
        const double v = 1.0 - u * u;
        return d2_6 * (1.0 - v * v * v);
      }
    }
    return 0.5 * a * a;
  }

  /// @brief IRLS weight rho'(r) / r of a residual r (sign ignored), in [0, 1].
  /// @note kNone gives 1 for any r; the other kernels give 0 for a NaN residual (the pair drops out).
  double weight(double r) const {
    if (kernel == RobustKernel::kNone) return 1.0;
    if (std::isnan(r)) return 0.0;
    const double a = std::abs(r);
    switch (kernel) {
      case RobustKernel::kNone: return 1.0;
      case RobustKernel::kHuber: return a <= scale ? 1.0 : scale / a;
      case RobustKernel::kCauchy: {
        const double u = a / scale;
        return 1.0 / (1.0 + u * u);
      }
      case RobustKernel::kTukey: {
        if (a >= scale) return 0.0;
        const double u = a / scale;
        const double v = 1.0 - u * u;
        return v * v;
      }
    }
    return 1.0;
  }

  /// @brief rho(s) of a squared norm s >= 0: s for kNone, and for kHuber up to s = d^2.
  double rho(double s) const {
    const double d2 = scale * scale;
    switch (kernel) {
      case RobustKernel::kNone: return s;
      case RobustKernel::kHuber: return s <= d2 ? s : 2.0 * scale * std::sqrt(s) - d2;
      case RobustKernel::kCauchy: return d2 * std::log1p(s / d2);
      case RobustKernel::kTukey: {
        if (s >= d2) return d2 / 3.0;
        const double v = 1.0 - s / d2;
        return d2 / 3.0 * (1.0 - v * v * v);
      }
    }
    return s;
  }

  /// @brief rho'(s) of a squared norm s >= 0, the IRLS weight of a residual block, in [0, 1]
  ///        (kHuber: 1 up to s = d^2).
  double rho_prime(double s) const {
    const double d2 = scale * scale;
    switch (kernel) {
      case RobustKernel::kNone: return 1.0;
      case RobustKernel::kHuber: return s <= d2 ? 1.0 : scale / std::sqrt(s);
      case RobustKernel::kCauchy: return 1.0 / (1.0 + s / d2);
      case RobustKernel::kTukey: {
        if (s >= d2) return 0.0;
        const double v = 1.0 - s / d2;
        return v * v;
      }
    }
    return 1.0;
  }
};

}  // namespace plumb
