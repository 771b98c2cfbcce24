// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief SO(3) and SE(3) exponential / logarithm maps and their Jacobians.
///
/// Conventions (as Sophus and Barfoot, "State Estimation for Robotics", ch. 7):
/// - a rotation vector `phi` (axis * angle) [rad]; `hat(phi)` its skew matrix;
/// - an SE(3) tangent `xi = [rho; phi]`, translation part first;
/// - left perturbations: `exp(delta) * T`; `J_l` the left Jacobian, `J_r(x) = J_l(-x)`.
/// Every function has a small-angle branch (Taylor series) so that it is exact to double
/// precision down to and including zero.

#include <cmath>

#include <Eigen/Geometry>

#include "plumb/core/types.hpp"

namespace plumb {

/// @brief Skew-symmetric matrix: hat(a) * b == a.cross(b).
inline Matrix3d hat(const Vector3d& v) {
  Matrix3d m;
  m << 0.0, -v.z(), v.y(), v.z(), 0.0, -v.x(), -v.y(), v.x(), 0.0;
  return m;
}

/// @brief Inverse of hat() for a skew-symmetric matrix (reads the lower-left entries).
inline Vector3d vee(const Matrix3d& m) { return {m(2, 1), m(0, 2), m(1, 0)}; }

namespace so3 {

namespace detail {
// Below this angle the closed forms lose digits to cancellation; the series are exact there.
constexpr double kSmallAngle = 1e-2;

// sin(t)/t
inline double sinc(double t) {
  if (t < kSmallAngle) { const double t2 = t * t; return 1.0 - t2 / 6.0 + t2 * t2 / 120.0; }
  return std::sin(t) / t;
}
// (1 - cos t)/t^2
inline double one_minus_cos_over_t2(double t) {
  if (t < kSmallAngle) { const double t2 = t * t; return 0.5 - t2 / 24.0 + t2 * t2 / 720.0; }
  return (1.0 - std::cos(t)) / (t * t);
}
// (t - sin t)/t^3
inline double t_minus_sin_over_t3(double t) {
  if (t < kSmallAngle) { const double t2 = t * t; return 1.0 / 6.0 - t2 / 120.0 + t2 * t2 / 5040.0; }
  return (t - std::sin(t)) / (t * t * t);
}
}  // namespace detail

/// @brief Exponential map: rotation vector -> rotation matrix (Rodrigues).
inline Matrix3d exp(const Vector3d& phi) {
  const double t = phi.norm();
  const Matrix3d K = hat(phi);
  return Matrix3d::Identity() + detail::sinc(t) * K + detail::one_minus_cos_over_t2(t) * K * K;
}

/// @brief Logarithm map: rotation matrix -> rotation vector with angle in [0, pi].
/// @note Goes through the unit quaternion (Shepperd's method inside Eigen), so it stays accurate
///       at 0 and at pi, where the trace formula loses all precision.
inline Vector3d log(const Matrix3d& R) {
  Eigen::Quaterniond q(R);
  q.normalize();
  if (q.w() < 0.0) q.coeffs() = -q.coeffs();  // angle in [0, pi]
  const Vector3d v = q.vec();
  const double n = v.norm();
  const double w = q.w();
  // phi = 2 atan2(n, w) * v / n; series of 2 atan2(n, w)/n for small n.
  double scale;
  if (n < 1e-8) {
    scale = 2.0 / w * (1.0 - n * n / (3.0 * w * w));
  } else {
    scale = 2.0 * std::atan2(n, w) / n;
  }
  return scale * v;
}

/// @brief Left Jacobian J_l(phi): exp(phi + d) ≈ exp(J_l d) exp(phi).
inline Matrix3d left_jacobian(const Vector3d& phi) {
  const double t = phi.norm();
  const Matrix3d K = hat(phi);
  return Matrix3d::Identity() + detail::one_minus_cos_over_t2(t) * K +
         detail::t_minus_sin_over_t3(t) * K * K;
}

/// @brief Right Jacobian J_r(phi) = J_l(-phi): exp(phi + d) ≈ exp(phi) exp(J_r d).
inline Matrix3d right_jacobian(const Vector3d& phi) { return left_jacobian(-phi); }

/// @brief Inverse of the left Jacobian (closed form).
/// @note Singular at |phi| = 2 pi; valid for angles in [0, pi] as returned by log().
inline Matrix3d left_jacobian_inverse(const Vector3d& phi) {
  const double t = phi.norm();
  const Matrix3d K = hat(phi);
  double c;  // (1/t^2 - (1 + cos t) / (2 t sin t))
  if (t < detail::kSmallAngle) {
    const double t2 = t * t;
    c = 1.0 / 12.0 + t2 / 720.0 + t2 * t2 / 30240.0;
  } else {
    c = 1.0 / (t * t) - (1.0 + std::cos(t)) / (2.0 * t * std::sin(t));
  }
  return Matrix3d::Identity() - 0.5 * K + c * K * K;
}

/// @brief Inverse of the right Jacobian: J_r^{-1}(phi) = J_l^{-1}(-phi).
inline Matrix3d right_jacobian_inverse(const Vector3d& phi) { return left_jacobian_inverse(-phi); }

}  // namespace so3

namespace se3 {

/// @brief The block Q(rho, phi) of the SE(3) left Jacobian (Barfoot 2017, eq. 7.86).
inline Matrix3d left_jacobian_q(const Vector3d& rho, const Vector3d& phi) {
  const double t = phi.norm();
  const Matrix3d P = hat(phi);
  const Matrix3d Rh = hat(rho);
  double c1, c2, c3;
  if (t < so3::detail::kSmallAngle) {
    const double t2 = t * t;
    c1 = 1.0 / 6.0 - t2 / 120.0 + t2 * t2 / 5040.0;
    c2 = 1.0 / 24.0 - t2 / 720.0 + t2 * t2 / 40320.0;
    c3 = 1.0 / 120.0 - t2 / 2520.0;
  } else {
    const double s = std::sin(t), c = std::cos(t);
    const double t2 = t * t, t4 = t2 * t2;
    c1 = (t - s) / (t2 * t);
    c2 = (t2 + 2.0 * c - 2.0) / (2.0 * t4);
    c3 = (2.0 * t - 3.0 * s + t * c) / (2.0 * t4 * t);
  }
  const Matrix3d PR = P * Rh;
  const Matrix3d RP = Rh * P;
  const Matrix3d PRP = PR * P;
  return 0.5 * Rh + c1 * (PR + RP + PRP) + c2 * (P * PR + RP * P - 3.0 * PRP) +
         c3 * (PRP * P + P * PRP);
}

/// @brief Exponential map: xi = [rho; phi] -> rigid transform.
inline Eigen::Isometry3d exp(const Vector6d& xi) {
  const Vector3d rho = xi.head<3>();
  const Vector3d phi = xi.tail<3>();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = so3::exp(phi);
  T.translation() = so3::left_jacobian(phi) * rho;
  return T;
}

/// @brief Logarithm map: rigid transform -> xi = [rho; phi] with |phi| in [0, pi].
inline Vector6d log(const Eigen::Isometry3d& T) {
  Vector6d xi;
  const Vector3d phi = so3::log(T.linear());
  xi.tail<3>() = phi;
  xi.head<3>() = so3::left_jacobian_inverse(phi) * T.translation();
  return xi;
}

/// @brief Adjoint: Ad(T) xi = log(T exp(xi) T^-1) to first order, for xi = [rho; phi].
inline Matrix6d adjoint(const Eigen::Isometry3d& T) {
  Matrix6d A = Matrix6d::Zero();
  const Matrix3d R = T.linear();
  A.topLeftCorner<3, 3>() = R;
  A.bottomRightCorner<3, 3>() = R;
  A.topRightCorner<3, 3>() = hat(T.translation()) * R;
  return A;
}

/// @brief Left Jacobian of SE(3): exp(xi + d) ≈ exp(J_l d) exp(xi).
inline Matrix6d left_jacobian(const Vector6d& xi) {
  const Vector3d rho = xi.head<3>();
  const Vector3d phi = xi.tail<3>();
  Matrix6d J = Matrix6d::Zero();
  const Matrix3d Jl = so3::left_jacobian(phi);
  J.topLeftCorner<3, 3>() = Jl;
  J.bottomRightCorner<3, 3>() = Jl;
  J.topRightCorner<3, 3>() = left_jacobian_q(rho, phi);
  return J;
}

/// @brief Right Jacobian of SE(3): J_r(xi) = J_l(-xi).
inline Matrix6d right_jacobian(const Vector6d& xi) { return left_jacobian(-xi); }

/// @brief Inverse of the SE(3) left Jacobian (block form, no 6x6 inversion).
inline Matrix6d left_jacobian_inverse(const Vector6d& xi) {
  const Vector3d rho = xi.head<3>();
  const Vector3d phi = xi.tail<3>();
  const Matrix3d Jinv = so3::left_jacobian_inverse(phi);
  Matrix6d J = Matrix6d::Zero();
  J.topLeftCorner<3, 3>() = Jinv;
  J.bottomRightCorner<3, 3>() = Jinv;
  J.topRightCorner<3, 3>() = -Jinv * left_jacobian_q(rho, phi) * Jinv;
  return J;
}

/// @brief Build an isometry from a rotation matrix and a translation.
inline Eigen::Isometry3d make(const Matrix3d& R, const Vector3d& t) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = R;
  T.translation() = t;
  return T;
}

}  // namespace se3

}  // namespace plumb
