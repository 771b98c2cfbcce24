// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cmath>
#include <ostream>

#include "plumb/core/types.hpp"

namespace plumb {

/// @brief Wrap an angle to (-pi, pi] [rad]. An angle already in range comes back unchanged (exactly).
inline double wrap_angle(double a) {
  if (a > -kPi && a <= kPi) return a;
  a = std::fmod(a + kPi, 2.0 * kPi);
  if (a <= 0.0) a += 2.0 * kPi;
  return a - kPi;
}

/// @brief An SE(2) pose or motion (x, y, theta), with the operators of Liu et al. 2022, eq. 13
/// (Censi et al., T-RO 2013, after Smith & Cheeseman).
///
/// `a.oplus(b)` composes b expressed in a's frame onto a; `a.ominus()` is the inverse. So the robot
/// motion between poses q_k and q_{k+1} is `r = q_k.ominus().oplus(q_{k+1})`.
/// Theta is not wrapped by the operators (eq. 13 adds angles); call wrapped() when needed.
struct Pose2 {
  double x = 0.0;      ///< [m]
  double y = 0.0;      ///< [m]
  double theta = 0.0;  ///< [rad]

  /// @brief a ⊕ b = (a_x + b_x cos a_θ - b_y sin a_θ, a_y + b_x sin a_θ + b_y cos a_θ, a_θ + b_θ).
  Pose2 oplus(const Pose2& b) const {
    const double c = std::cos(theta), s = std::sin(theta);
    return {x + c * b.x - s * b.y, y + s * b.x + c * b.y, theta + b.theta};
  }

  /// @brief ⊖a = (-a_x cos a_θ - a_y sin a_θ, a_x sin a_θ - a_y cos a_θ, -a_θ).
  Pose2 ominus() const {
    const double c = std::cos(theta), s = std::sin(theta);
    return {-x * c - y * s, x * s - y * c, -theta};
  }

  /// @brief The same pose with theta wrapped to (-pi, pi].
  Pose2 wrapped() const { return {x, y, wrap_angle(theta)}; }

  /// @brief Apply the pose to a 2D point: R(theta) p + t.
  Vector2d operator*(const Vector2d& p) const {
    const double c = std::cos(theta), s = std::sin(theta);
    return {c * p.x() - s * p.y() + x, s * p.x() + c * p.y() + y};
  }

  /// @brief 3x3 homogeneous matrix [R t; 0 1].
  Eigen::Matrix3d matrix() const {
    Eigen::Matrix3d m = Eigen::Matrix3d::Identity();
    const double c = std::cos(theta), s = std::sin(theta);
    m << c, -s, x, s, c, y, 0, 0, 1;
    return m;
  }

  /// @brief The planar pose as a 3D isometry (rotation about z, z = 0).
  Eigen::Isometry3d to_isometry() const {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = Eigen::AngleAxisd(theta, Vector3d::UnitZ()).toRotationMatrix();
    T.translation() = Vector3d(x, y, 0.0);
    return T;
  }

  /// @brief Project a 3D isometry to SE(2): x, y and the yaw of its rotation.
  static Pose2 from_isometry(const Eigen::Isometry3d& T) {
    const Eigen::Matrix3d& R = T.linear();
    return {T.translation().x(), T.translation().y(), std::atan2(R(1, 0), R(0, 0))};
  }

  Eigen::Vector3d vector() const { return {x, y, theta}; }
};

inline std::ostream& operator<<(std::ostream& os, const Pose2& p) {
  return os << "Pose2(" << p.x << ", " << p.y << ", " << p.theta << ")";
}

}  // namespace plumb
