// SPDX-License-Identifier: BSD-3-Clause
// Property tests of the SO(3)/SE(3) maps: exp(log(x)) == x, log(exp(v)) == v, and every analytic
// Jacobian against central differences, over random samples and the awkward angles (0, tiny, pi).
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "plumb/core/lie.hpp"
#include "plumb/core/rng.hpp"

namespace plumb {
namespace {


Vector3d random_unit(Rng& rng) {
  Vector3d v(rng.normal(), rng.normal(), rng.normal());
  return v.normalized();
}

// Rotation vectors covering the branches: zero, below/above the series threshold, generic, near pi.
std::vector<Vector3d> sample_rotation_vectors() {
  Rng rng(7);
  std::vector<Vector3d> out;
  out.push_back(Vector3d::Zero());
  for (double angle : {1e-12, 1e-8, 1e-5, 9e-3, 1.1e-2, 0.1, 0.5, 1.0, 2.0, 3.0, kPi - 1e-6, kPi - 1e-9}) {
    for (int i = 0; i < 4; ++i) out.push_back(angle * random_unit(rng));
  }
  for (int i = 0; i < 40; ++i) out.push_back(rng.uniform(0.0, kPi - 1e-3) * random_unit(rng));
  return out;
}

TEST(So3Test, HatVeeRoundTripAndCrossProduct) {
  const Vector3d a(0.3, -1.2, 2.5), b(-0.7, 0.4, 1.1);
  EXPECT_TRUE(vee(hat(a)).isApprox(a));
  EXPECT_TRUE((hat(a) * b).isApprox(a.cross(b)));
  EXPECT_TRUE((hat(a) + hat(a).transpose()).isZero());
}

TEST(So3Test, ExpIsARotationMatchingAngleAxis) {
  for (const Vector3d& phi : sample_rotation_vectors()) {
    const Matrix3d R = so3::exp(phi);
    EXPECT_NEAR((R.transpose() * R - Matrix3d::Identity()).norm(), 0.0, 1e-13);
    EXPECT_NEAR(R.determinant(), 1.0, 1e-13);
    const double angle = phi.norm();
    const Matrix3d ref = angle > 0 ? Eigen::AngleAxisd(angle, phi / angle).toRotationMatrix()
                                   : Matrix3d::Identity();
    EXPECT_LT((R - ref).norm(), 1e-13) << "phi " << phi.transpose();
  }
}

TEST(So3Test, LogInvertsExp) {
  for (const Vector3d& phi : sample_rotation_vectors()) {
    const Vector3d back = so3::log(so3::exp(phi));
    // Near pi the sign of the axis is ambiguous when the angle is exactly pi; below it, it is not.
    EXPECT_LT((back - phi).norm(), 1e-9 * std::max(1.0, 1.0 / (kPi - phi.norm() + 1e-3)))
        << "phi " << phi.transpose() << " back " << back.transpose();
    EXPECT_LT((so3::exp(back) - so3::exp(phi)).norm(), 1e-12);
  }
}

TEST(So3Test, LogAtExactlyPiGivesAngleAxisOfPi) {
  Rng rng(3);
  for (int i = 0; i < 10; ++i) {
    const Vector3d axis = random_unit(rng);
    const Matrix3d R = Eigen::AngleAxisd(kPi, axis).toRotationMatrix();
    const Vector3d phi = so3::log(R);
    EXPECT_NEAR(phi.norm(), kPi, 1e-9);
    EXPECT_NEAR(std::abs(phi.normalized().dot(axis)), 1.0, 1e-9);
    EXPECT_LT((so3::exp(phi) - R).norm(), 1e-9);
  }
}

TEST(So3Test, ExpOfSumOfParallelVectorsIsProduct) {
  const Vector3d axis = Vector3d(1, 2, 3).normalized();
  const Matrix3d a = so3::exp(0.4 * axis), b = so3::exp(0.9 * axis);
  EXPECT_LT((a * b - so3::exp(1.3 * axis)).norm(), 1e-14);
}

// exp(phi + d) ≈ exp(J_l d) exp(phi): numeric J_l from central differences of log(exp(phi + d) exp(phi)^T).
TEST(So3Test, LeftAndRightJacobiansMatchNumeric) {
  const double h = 1e-6;
  for (const Vector3d& phi : sample_rotation_vectors()) {
    if (phi.norm() > kPi - 1e-2) continue;  // the perturbed log wraps at pi
    Matrix3d Jl_num, Jr_num;
    for (int k = 0; k < 3; ++k) {
      const Vector3d d = h * Vector3d::Unit(k);
      const Matrix3d Rp = so3::exp(phi + d), Rm = so3::exp(phi - d), R = so3::exp(phi);
      Jl_num.col(k) = (so3::log(Rp * R.transpose()) - so3::log(Rm * R.transpose())) / (2 * h);
      Jr_num.col(k) = (so3::log(R.transpose() * Rp) - so3::log(R.transpose() * Rm)) / (2 * h);
    }
    EXPECT_LT((so3::left_jacobian(phi) - Jl_num).norm(), 1e-7) << "phi " << phi.transpose();
    EXPECT_LT((so3::right_jacobian(phi) - Jr_num).norm(), 1e-7) << "phi " << phi.transpose();
  }
}

TEST(So3Test, JacobianInversesAreInverses) {
  for (const Vector3d& phi : sample_rotation_vectors()) {
    if (phi.norm() > kPi - 1e-3) continue;
    EXPECT_LT((so3::left_jacobian(phi) * so3::left_jacobian_inverse(phi) - Matrix3d::Identity()).norm(),
              1e-10);
    EXPECT_LT((so3::right_jacobian(phi) * so3::right_jacobian_inverse(phi) - Matrix3d::Identity()).norm(),
              1e-10);
  }
}

std::vector<Vector6d> sample_twists() {
  Rng rng(11);
  std::vector<Vector6d> out;
  for (const Vector3d& phi : sample_rotation_vectors()) {
    if (phi.norm() > kPi - 1e-3) continue;
    Vector6d xi;
    xi << rng.normal(0, 3), rng.normal(0, 3), rng.normal(0, 3), phi;
    out.push_back(xi);
  }
  out.push_back(Vector6d::Zero());
  return out;
}

TEST(Se3Test, LogInvertsExpAndExpInvertsLog) {
  for (const Vector6d& xi : sample_twists()) {
    const Eigen::Isometry3d T = se3::exp(xi);
    EXPECT_LT((se3::log(T) - xi).norm(), 1e-9) << xi.transpose();
    EXPECT_LT((se3::exp(se3::log(T)).matrix() - T.matrix()).norm(), 1e-12);
  }
}

TEST(Se3Test, PureTranslationAndPureRotation) {
  Vector6d xi = Vector6d::Zero();
  xi.head<3>() = Vector3d(1, -2, 3);
  EXPECT_TRUE(se3::exp(xi).translation().isApprox(Vector3d(1, -2, 3)));
  EXPECT_TRUE(se3::exp(xi).linear().isIdentity());
  xi.setZero();
  xi.tail<3>() = Vector3d(0, 0, 0.5);
  EXPECT_TRUE(se3::exp(xi).translation().isZero());
  EXPECT_TRUE(se3::exp(xi).linear().isApprox(so3::exp(Vector3d(0, 0, 0.5))));
}

TEST(Se3Test, ExpOfTwistIsScrewMotion) {
  // A twist integrates a constant body velocity: exp(xi) == exp(xi/n)^n.
  for (const Vector6d& xi : sample_twists()) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    const Eigen::Isometry3d step = se3::exp(xi / 8.0);
    for (int i = 0; i < 8; ++i) T = T * step;
    EXPECT_LT((T.matrix() - se3::exp(xi).matrix()).norm(), 1e-10);
  }
}

TEST(Se3Test, AdjointMovesPerturbations) {
  // T exp(xi) T^-1 == exp(Ad(T) xi)
  Rng rng(5);
  for (const Vector6d& a : sample_twists()) {
    Vector6d xi;
    for (int k = 0; k < 6; ++k) xi[k] = rng.normal(0, 0.3);
    const Eigen::Isometry3d T = se3::exp(a);
    const Eigen::Isometry3d lhs = T * se3::exp(xi) * T.inverse();
    const Eigen::Isometry3d rhs = se3::exp(se3::adjoint(T) * xi);
    EXPECT_LT((lhs.matrix() - rhs.matrix()).norm(), 1e-10);
  }
}

TEST(Se3Test, LeftAndRightJacobiansMatchNumeric) {
  const double h = 1e-6;
  for (const Vector6d& xi : sample_twists()) {
    if (xi.tail<3>().norm() > 3.0) continue;
    Matrix6d Jl_num, Jr_num;
    const Eigen::Isometry3d T = se3::exp(xi), T_inv = T.inverse();
    for (int k = 0; k < 6; ++k) {
      const Vector6d d = h * Vector6d::Unit(k);
      const Eigen::Isometry3d Tp = se3::exp(xi + d), Tm = se3::exp(xi - d);
      Jl_num.col(k) = (se3::log(Tp * T_inv) - se3::log(Tm * T_inv)) / (2 * h);
      Jr_num.col(k) = (se3::log(T_inv * Tp) - se3::log(T_inv * Tm)) / (2 * h);
    }
    EXPECT_LT((se3::left_jacobian(xi) - Jl_num).norm(), 1e-6) << xi.transpose();
    EXPECT_LT((se3::right_jacobian(xi) - Jr_num).norm(), 1e-6) << xi.transpose();
    EXPECT_LT((se3::left_jacobian(xi) * se3::left_jacobian_inverse(xi) - Matrix6d::Identity()).norm(),
              1e-9);
  }
}

TEST(Se3Test, SeriesBranchIsContinuousAtThreshold) {
  // Q just below and just above the small-angle threshold must agree to first order in the step.
  const Vector3d axis = Vector3d(0.2, -0.5, 0.8).normalized();
  const Vector3d rho(1.0, 2.0, -0.5);
  const double t = so3::detail::kSmallAngle;
  const Matrix3d below = se3::left_jacobian_q(rho, (t * (1 - 1e-9)) * axis);
  const Matrix3d above = se3::left_jacobian_q(rho, (t * (1 + 1e-9)) * axis);
  EXPECT_LT((below - above).norm(), 1e-10);
}

}  // namespace
}  // namespace plumb
