// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// @brief Horn's closed-form absolute orientation with unit quaternions (Liu et al. 2022, sec. 1.3, eq. 5-6).

#include <cstddef>
#include <vector>

#include <Eigen/Geometry>

#include "plumb/core/types.hpp"

namespace plumb {

/// @brief Rigid transform that best maps source points onto paired target points.
struct HornResult {
  Eigen::Isometry3d T_target_source = Eigen::Isometry3d::Identity();  ///< identity when !valid
  bool valid = false;         ///< false for < 3 pairs, zero total weight or a degenerate (collinear) set
  std::size_t num_pairs = 0;  ///< pairs with positive weight that entered the estimate
  double rmse = 0.0;          ///< weighted RMS distance |T p - q| after alignment [m]
};

/// @brief Weighted sums of point pairs from which Horn's closed form solves the rotation and
///        translation (Horn 1987, "Closed-form solution of absolute orientation using unit
///        quaternions"). Add pairs one at a time (no storage), then call solve().
/// @note Pairs are accumulated relative to the first pair's points, in double, so large
///       coordinates (site frames) do not lose digits. Deterministic for a given add() order.
class HornAccumulator {
 public:
  /// @brief Add the pair (source point p, target point q) with weight w >= 0 (w = 0 is ignored).
  void add(const Vector3d& p, const Vector3d& q, double w = 1.0) {
    if (!(w > 0.0)) return;
    if (n_ == 0) { p0_ = p; q0_ = q; }
    const Vector3d a = p - p0_;
    const Vector3d b = q - q0_;
    w_sum_ += w;
    p_sum_ += w * a;
    q_sum_ += w * b;
    pq_sum_.noalias() += (w * a) * b.transpose();
    pp_sum_ += w * a.squaredNorm();
    qq_sum_ += w * b.squaredNorm();
    ++n_;
  }
  /// @brief Number of pairs with positive weight added so far.
  std::size_t size() const { return n_; }
  /// @brief Solve the closed form; see HornResult for validity.
  HornResult solve() const;

 private:
  std::size_t n_ = 0;
  double w_sum_ = 0.0, pp_sum_ = 0.0, qq_sum_ = 0.0;
  Vector3d p0_ = Vector3d::Zero(), q0_ = Vector3d::Zero();
  Vector3d p_sum_ = Vector3d::Zero(), q_sum_ = Vector3d::Zero();
  Matrix3d pq_sum_ = Matrix3d::Zero();
};

/// @brief Horn's closed form for paired point sets (source[i] <-> target[i]).
/// @param weights optional per-pair weights (>= 0), same length as the point sets
/// @throws plumb::Error when the lengths differ or a point or weight is not finite
HornResult horn_align(const std::vector<Vector3d>& source, const std::vector<Vector3d>& target,
                      const std::vector<double>* weights = nullptr);

}  // namespace plumb
