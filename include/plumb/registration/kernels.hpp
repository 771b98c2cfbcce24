// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// @brief Robust kernels: the Huber penalty of SAC-IA (Liu et al. 2022, eq. 2) and IRLS weights for ICP.

#include <cmath>

namespace plumb {

/// @brief Robust loss applied to residuals (IRLS weights in ICP).
enum class RobustKernel {
  kNone,    ///< plain least squares, weight 1
  kHuber,   ///< quadratic inside the scale, linear outside
  kCauchy,  ///< log(1 + (r/s)^2), weight 1 / (1 + (r/s)^2)
  kTukey,   ///< biweight: zero weight beyond the scale
};

/// @brief Huber penalty of Liu et al. 2022, eq. 2: `l^2/2` if `|l| < m1`, else `m1 (2|l| - m1) / 2`.
/// @param l residual (a distance) [m]; @param m1 threshold [m], > 0
inline double huber_penalty(double l, double m1) {
  const double a = std::abs(l);
  return a < m1 ? 0.5 * a * a : 0.5 * m1 * (2.0 * a - m1);
}

/// @brief IRLS weight w(r) = rho'(r) / r of a kernel at residual r with scale s > 0.
/// @note Every kernel gives 1 at r = 0 and a weight in [0, 1]; NaN residuals get weight 0.
inline double robust_weight(RobustKernel kernel, double r, double s) {
  if (std::isnan(r)) return 0.0;
  const double a = std::abs(r);
  switch (kernel) {
    case RobustKernel::kNone: return 1.0;
    case RobustKernel::kHuber: return a <= s ? 1.0 : s / a;
    case RobustKernel::kCauchy: { const double u = a / s; return 1.0 / (1.0 + u * u); }
    case RobustKernel::kTukey: {
      if (a >= s) return 0.0;
      const double u = a / s;
      const double v = 1.0 - u * u;
      return v * v;
    }
  }
  return 1.0;
}

}  // namespace plumb
