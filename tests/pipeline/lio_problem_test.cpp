// SPDX-License-Identifier: BSD-3-Clause
// The blocks of HybridLio's joint problem, checked on their own: the analytic gradient of every
// residual kind (LOAM edge and plane, ICP point, point-to-distribution weights, IMU factor, prior)
// against central differences of the cost, and Gauss-Newton on the assembled system returning to
// states every residual agrees on.
#include <gtest/gtest.h>

#include <random>
#include <vector>

#include <Eigen/Eigenvalues>

#include "../../src/pipeline/lio_problem.hpp"
#include "plumb/core/lie.hpp"

namespace plumb {
namespace {

using lio_detail::JointProblem;
using lio_detail::Matrix30d;
using lio_detail::Vector30d;

Vector3d random_unit(std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  return Vector3d(n(rng), n(rng), n(rng)).normalized();
}

/// A short IMU interval: turning and accelerating, integrated at 200 Hz.
ImuPreintegration some_preintegration(const ImuBias& bias) {
  ImuPreintegration pim(bias);
  for (int k = 0; k < 20; ++k) {
    pim.add_measurement(Vector3d(0.05, -0.02, 0.3 + 0.01 * k), Vector3d(0.4, 0.1 * k / 20.0, 9.81), 0.005);
  }
  return pim;
}

/// Correspondences of every kind whose query points, seen from `truth`, lie exactly on their line,
/// plane or point (all residuals zero there); query points are given in the LiDAR frame with the
/// IMU frame equal to it.
void exact_correspondences(const ImuState& truth, std::mt19937& rng, std::vector<LoamCorrespondence>& corr,
                           std::vector<Vector3d>& s_imu) {
  std::uniform_real_distribution<double> u(-5.0, 5.0);
  const Eigen::Isometry3d T = se3::make(truth.R_world_body, truth.p_world_body);
  for (int k = 0; k < 30; ++k) {
    LoamCorrespondence c;
    c.kind = k % 3 == 0 ? LoamCorrespondence::Kind::kEdge
                        : (k % 3 == 1 ? LoamCorrespondence::Kind::kPlane : LoamCorrespondence::Kind::kPoint);
    c.p = Vector3d(u(rng), u(rng), u(rng));
    const Vector3d q = T * c.p;
    c.dir = random_unit(rng);
    if (c.kind == LoamCorrespondence::Kind::kEdge) {
      c.a = q + 0.7 * u(rng) * c.dir;  // on the line
    } else if (c.kind == LoamCorrespondence::Kind::kPlane) {
      c.a = q + 0.5 * u(rng) * c.dir.unitOrthogonal();  // in the plane
    } else {
      c.a = q;
    }
    c.weight = k % 4 == 0 ? 0.3 : 1.0;  // point-to-distribution pairs whiten with weights != 1
    corr.push_back(c);
    s_imu.push_back(c.p);
  }
}

HybridLioSettings problem_settings(double huber_scale) {
  HybridLioSettings s;
  s.solver.plane_sigma = 0.05;
  s.solver.edge_sigma = 0.08;
  s.solver.point_sigma = 0.1;
  s.solver.huber_scale = huber_scale;
  return s;
}

/// Central differences of the cost along each unknown against the analytic gradient g.
void expect_gradient_matches(const JointProblem& problem, const ImuState& xi, const ImuState& xj,
                             const std::vector<LoamCorrespondence>& corr, const std::vector<Vector3d>& s_imu) {
  Matrix30d H;
  Vector30d g;
  double sum_sq = 0.0;
  const double cost = problem.build(xi, xj, corr, s_imu, &H, &g, &sum_sq);
  ASSERT_GT(cost, 0.0);
  EXPECT_GT(sum_sq, 0.0);
  const double eps = 1e-6;
  for (int k = 0; k < problem.dim(); ++k) {
    Vector30d d = Vector30d::Zero();
    d[k] = eps;
    ImuState a1, b1, a2, b2;
    problem.step(d, xi, xj, a1, b1);
    problem.step(-d, xi, xj, a2, b2);
    const double numeric = (problem.build(a1, b1, corr, s_imu, nullptr, nullptr, nullptr) -
                            problem.build(a2, b2, corr, s_imu, nullptr, nullptr, nullptr)) /
                           (2.0 * eps);
    EXPECT_NEAR(g[k], numeric, 1e-5 * std::max(1.0, std::abs(numeric))) << "unknown " << k;
  }
  // The Gauss-Newton matrix is symmetric and positive semi-definite.
  const Eigen::MatrixXd A = H.topLeftCorner(problem.dim(), problem.dim());
  EXPECT_LT((A - A.transpose()).cwiseAbs().maxCoeff(), 1e-9 * A.cwiseAbs().maxCoeff());
  EXPECT_GT(Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(A).eigenvalues().minCoeff(), -1e-9 * A.norm());
}

TEST(LioProblemTest, GradientOfTheLidarTermsMatchesCentralDifferences) {
  std::mt19937 rng(3);
  ImuState truth;
  truth.R_world_body = so3::exp(Vector3d(0.1, -0.2, 0.7));
  truth.p_world_body = Vector3d(1.0, 2.0, 0.5);
  std::vector<LoamCorrespondence> corr;
  std::vector<Vector3d> s_imu;
  exact_correspondences(truth, rng, corr, s_imu);
  Vector15d off = Vector15d::Zero();
  off.head<6>() << 0.02, -0.01, 0.03, 0.04, -0.05, 0.02;
  const ImuState xj = retract(truth, off);
  const Matrix15d info = Matrix15d::Identity();
  for (double huber : {1e6, 0.5}) {  // quadratic everywhere; robust (some residuals beyond the scale)
    const HybridLioSettings set = problem_settings(huber);
    const JointProblem problem(set, nullptr, truth, info);
    ASSERT_EQ(problem.dim(), 6);
    expect_gradient_matches(problem, truth, xj, corr, s_imu);
  }
}

TEST(LioProblemTest, GradientOfTheJointImuProblemMatchesCentralDifferences) {
  std::mt19937 rng(5);
  ImuState xi;
  xi.R_world_body = so3::exp(Vector3d(0.05, 0.02, -0.4));
  xi.p_world_body = Vector3d(-1.0, 0.5, 0.3);
  xi.v_world = Vector3d(0.8, 0.1, 0.0);
  xi.bias.gyro = Vector3d(0.001, -0.002, 0.0005);
  xi.bias.accel = Vector3d(0.02, 0.01, -0.03);
  const ImuPreintegration pim = some_preintegration(xi.bias);
  const ImuState truth_j = pim.predict(xi);
  std::vector<LoamCorrespondence> corr;
  std::vector<Vector3d> s_imu;
  exact_correspondences(truth_j, rng, corr, s_imu);
  Vector15d info_diag;
  info_diag << Vector3d::Constant(1e4), Vector3d::Constant(1e2), Vector3d::Constant(10.0), Vector3d::Constant(1e3),
      Vector3d::Constant(1e2);
  const Matrix15d prior_information = info_diag.asDiagonal();
  const HybridLioSettings set = problem_settings(0.5);
  const JointProblem problem(set, &pim, xi, prior_information);
  ASSERT_EQ(problem.dim(), 30);
  ASSERT_EQ(problem.offset_j(), 15);
  // Both states off the truth in every block, so the prior, IMU and LiDAR terms all contribute.
  std::normal_distribution<double> n(0.0, 0.02);
  Vector30d off;
  for (int k = 0; k < 30; ++k) off[k] = n(rng);
  ImuState a, b;
  problem.step(off, xi, truth_j, a, b);
  expect_gradient_matches(problem, a, b, corr, s_imu);
}

TEST(LioProblemTest, GaussNewtonReturnsToTheStatesEveryResidualAgreesOn) {
  std::mt19937 rng(11);
  ImuState xi;
  xi.R_world_body = so3::exp(Vector3d(-0.1, 0.05, 1.2));
  xi.p_world_body = Vector3d(3.0, -2.0, 0.4);
  xi.v_world = Vector3d(0.5, -0.3, 0.05);
  const ImuPreintegration pim = some_preintegration(xi.bias);
  const ImuState truth_j = pim.predict(xi);
  std::vector<LoamCorrespondence> corr;
  std::vector<Vector3d> s_imu;
  exact_correspondences(truth_j, rng, corr, s_imu);
  const Matrix15d prior_information = 1e2 * Matrix15d::Identity();
  const HybridLioSettings set = problem_settings(1e6);
  const JointProblem problem(set, &pim, xi, prior_information);
  Vector30d off;
  std::normal_distribution<double> n(0.0, 0.03);
  for (int k = 0; k < 30; ++k) off[k] = n(rng);
  ImuState a, b;
  problem.step(off, xi, truth_j, a, b);
  for (int it = 0; it < 10; ++it) {
    Matrix30d H;
    Vector30d g;
    double sum_sq = 0.0;
    problem.build(a, b, corr, s_imu, &H, &g, &sum_sq);
    const Vector30d delta = H.ldlt().solve(-g);
    ImuState a2, b2;
    problem.step(delta, a, b, a2, b2);
    a = a2;
    b = b2;
  }
  EXPECT_NEAR(problem.build(a, b, corr, s_imu, nullptr, nullptr, nullptr), 0.0, 1e-16);
  EXPECT_LT((a.p_world_body - xi.p_world_body).norm(), 1e-9);
  EXPECT_LT(so3::log(xi.R_world_body.transpose() * a.R_world_body).norm(), 1e-9);
  EXPECT_LT((b.p_world_body - truth_j.p_world_body).norm(), 1e-9);
  EXPECT_LT(so3::log(truth_j.R_world_body.transpose() * b.R_world_body).norm(), 1e-9);
  EXPECT_LT((b.v_world - truth_j.v_world).norm(), 1e-9);
}

}  // namespace
}  // namespace plumb
