// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief LOAM residuals (Zhou et al. 2021, sec. 1.3, eq. 6-8) and the point-to-point ICP residual
/// (eq. 20), with analytic Jacobians w.r.t. a right perturbation of the pose: `T <- T * exp(delta)`,
/// `delta = [rho; phi]` (translation first, as in plumb/core/lie.hpp).
///
/// Every residual is a function of `q = T * p` for a query point p of the current frame; to first
/// order `T exp(delta) p = q + R (rho + phi x p)`, so `d q / d delta = [R, -R hat(p)]`.

#include <algorithm>
#include <optional>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "plumb/core/lie.hpp"
#include "plumb/core/types.hpp"

namespace plumb {

using Matrix36d = Eigen::Matrix<double, 3, 6>;
using Matrix16d = Eigen::Matrix<double, 1, 6>;

/// @brief Jacobian of `T * p` w.r.t. the right perturbation of T: `[R, -R hat(p)]`.
inline Matrix36d transform_point_jacobian(const Eigen::Isometry3d& T, const Vector3d& p) {
  Matrix36d J;
  const Matrix3d R = T.linear();
  J.leftCols<3>() = R;
  J.rightCols<3>() = -R * hat(p);
  return J;
}

/// @brief Point-to-edge residual (Zhou et al. 2021, eq. 6): `r = u x (T p - a)` with u the unit direction of
///        the line through a and b. |r| is eq. 6's distance `|(q - a) x (q - b)| / |a - b|`.
/// @param J_r_xi if not null, receives dr/d delta (3x6)
/// @note a and b must differ; the caller checks (see make_edge_line()).
inline Vector3d point_to_edge_residual(const Eigen::Isometry3d& T, const Vector3d& p, const Vector3d& a,
                                       const Vector3d& u, Matrix36d* J_r_xi = nullptr) {
  const Vector3d q = T * p;
  if (J_r_xi != nullptr) *J_r_xi = hat(u) * transform_point_jacobian(T, p);
  return u.cross(q - a);
}

/// @brief Point-to-plane residual (Zhou et al. 2021, eq. 7): signed distance `r = n . (T p - a)`, n unit.
/// @param J_r_xi if not null, receives dr/d delta (1x6)
inline double point_to_plane_residual(const Eigen::Isometry3d& T, const Vector3d& p, const Vector3d& a,
                                      const Vector3d& n, Matrix16d* J_r_xi = nullptr) {
  const Vector3d q = T * p;
  if (J_r_xi != nullptr) *J_r_xi = n.transpose() * transform_point_jacobian(T, p);
  return n.dot(q - a);
}

/// @brief Point-to-point residual (Zhou et al. 2021, eq. 20): `r = T p - m`.
/// @param J_r_xi if not null, receives dr/d delta (3x6)
inline Vector3d point_to_point_residual(const Eigen::Isometry3d& T, const Vector3d& p, const Vector3d& m,
                                        Matrix36d* J_r_xi = nullptr) {
  if (J_r_xi != nullptr) *J_r_xi = transform_point_jacobian(T, p);
  return T * p - m;
}

/// @brief Unit direction of the line through j and l, or nothing when they are closer than min_separation [m].
inline std::optional<Vector3d> make_edge_line(const Vector3d& j, const Vector3d& l, double min_separation = 1e-6) {
  const Vector3d d = l - j;
  const double len = d.norm();
  if (!(len > min_separation)) return std::nullopt;
  return Vector3d(d / len);
}

/// @brief Unit normal of the plane through j, l, m (eq. 7), or nothing when the three points are
///        (nearly) collinear: the triangle's smallest height is below min_height [m].
inline std::optional<Vector3d> make_plane_normal(const Vector3d& j, const Vector3d& l, const Vector3d& m,
                                                 double min_height = 1e-4) {
  const Vector3d c = (l - j).cross(m - j);
  const double area2 = c.norm();  // twice the area
  const double longest = std::max({(l - j).norm(), (m - j).norm(), (m - l).norm()});
  if (!(longest > 0.0) || !(area2 / longest > min_height)) return std::nullopt;
  return Vector3d(c / area2);
}

}  // namespace plumb
