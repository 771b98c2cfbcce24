// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Robust losses rho(s) on the squared norm s = |r|^2 of a residual block, for the
///        least-squares solver (cost 1/2 sum rho(s_k); IRLS weight rho'(s)).
/// @note plumb/registration/kernels.hpp weights scalar distances for ICP; these act on whole
///       residual blocks and also give the loss value, which the LM step acceptance needs.

#include <cmath>

#include "plumb/core/error.hpp"

namespace plumb {

/// @brief Kind of robust loss.
enum class LossKind {
  kNone,    ///< rho(s) = s
  kHuber,   ///< rho(s) = s for s <= d^2, 2 d sqrt(s) - d^2 beyond: linear in |r| past the scale
  kCauchy,  ///< rho(s) = d^2 log(1 + s / d^2): far outliers have a vanishing influence
};

/// @brief A robust loss with its scale d (in the residual's units, e.g. [m]).
struct RobustLoss {
  LossKind kind = LossKind::kNone;  ///< kind of loss
  double scale = 1.0;               ///< d > 0: residual norm where the loss leaves the quadratic

  static RobustLoss none() { return {}; }
  /// @throws plumb::Error when scale is not positive and finite.
  static RobustLoss huber(double scale) { return make(LossKind::kHuber, scale); }
  /// @throws plumb::Error when scale is not positive and finite.
  static RobustLoss cauchy(double scale) { return make(LossKind::kCauchy, scale); }

  /// @brief rho(s) for a squared norm s >= 0.
  double rho(double s) const {
    const double d2 = scale * scale;
    switch (kind) {
      case LossKind::kNone: return s;
      case LossKind::kHuber: return s <= d2 ? s : 2.0 * scale * std::sqrt(s) - d2;
      case LossKind::kCauchy: return d2 * std::log1p(s / d2);
    }
    return s;
  }

  /// @brief rho'(s), the IRLS weight of the residual block: 1 inside the scale, in (0, 1] beyond.
  double weight(double s) const {
    const double d2 = scale * scale;
    switch (kind) {
      case LossKind::kNone: return 1.0;
      case LossKind::kHuber: return s <= d2 ? 1.0 : scale / std::sqrt(s);
      case LossKind::kCauchy: return 1.0 / (1.0 + s / d2);
    }
    return 1.0;
  }

 private:
  static RobustLoss make(LossKind kind, double scale) {
    PLUMB_CHECK(scale > 0.0 && std::isfinite(scale), "RobustLoss: scale must be positive, got " << scale);
    RobustLoss l;
    l.kind = kind;
    l.scale = scale;
    return l;
  }
};

}  // namespace plumb
