// SPDX-License-Identifier: BSD-3-Clause
// The one Levenberg-Marquardt step: the damped system it solves (against an independent LU solve),
// how the damping moves on acceptance and rejection and where it stops, and a solver loop built on
// it reaching the known minimum of Rosenbrock's function.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include <Eigen/Eigenvalues>
#include <Eigen/LU>

#include "plumb/core/error.hpp"
#include "plumb/core/levenberg_marquardt.hpp"

namespace plumb {
namespace {

using Matrix3 = Eigen::Matrix3d;
using Vector3 = Eigen::Vector3d;

/// A convex quadratic c + g^T d + 1/2 d^T H d around the current point.
struct Quadratic {
  Matrix3 H;
  Vector3 g;
  double c = 2.0;
  double operator()(const Vector3& d) const { return c + g.dot(d) + 0.5 * d.dot(H * d); }
};

Quadratic some_quadratic() {
  Quadratic q;
  q.H << 4.0, 1.0, 0.05, 1.0, 3.0, 0.02, 0.05, 0.02, 0.01;  // positive definite; the third direction weak
  q.g << -1.0, 2.0, 0.3;
  return q;
}

Vector3 damped_solution(const Quadratic& q, double lambda) {
  Matrix3 A = q.H;
  for (int d = 0; d < 3; ++d) A(d, d) += lambda * std::max(q.H(d, d), 1e-9);
  return A.fullPivLu().solve(-q.g);
}

TEST(LevenbergMarquardtTest, AcceptedStepSolvesTheDampedSystemAndShrinksTheDamping) {
  const Quadratic q = some_quadratic();
  ASSERT_GT(Eigen::SelfAdjointEigenSolver<Matrix3>(q.H).eigenvalues().minCoeff(), 0.0);  // convex
  LevenbergMarquardtSettings settings;
  settings.initial_lambda = 0.5;
  LevenbergMarquardt lm(settings);
  Vector3 delta;
  ASSERT_TRUE(lm.step(q.H, q.g, q.c, q, delta));
  EXPECT_LT((delta - damped_solution(q, 0.5)).norm(), 1e-12);
  EXPECT_LT(q(delta), q.c);
  EXPECT_DOUBLE_EQ(lm.lambda(), 0.05);
  EXPECT_EQ(lm.num_rejected(), 0);
}

TEST(LevenbergMarquardtTest, RejectedStepsGrowTheDampingUntilAStepIsShortEnough) {
  // A cost that is the quadratic inside a radius and worse than the current point outside it (a
  // trust region the solver does not know): the damping grows tenfold per rejection.
  const Quadratic q = some_quadratic();
  const double radius = 0.05;
  const auto cost_of = [&](const Vector3& d) { return d.norm() <= radius ? q(d) : q.c + 1.0; };
  ASSERT_GT(damped_solution(q, 1e-4).norm(), radius);
  LevenbergMarquardt lm;  // lambda 1e-4
  Vector3 delta;
  ASSERT_TRUE(lm.step(q.H, q.g, q.c, cost_of, delta));
  EXPECT_LE(delta.norm(), radius);
  const int rejected = lm.num_rejected();
  ASSERT_GE(rejected, 1);
  // The accepted step is the damped solution at the grown damping, the first one short enough.
  const double used = 1e-4 * std::pow(10.0, rejected);
  EXPECT_LT((delta - damped_solution(q, used)).norm(), 1e-9);
  EXPECT_GT(damped_solution(q, used / 10.0).norm(), radius);
  EXPECT_NEAR(lm.lambda(), used / 10.0, 1e-12 * used);
}

TEST(LevenbergMarquardtTest, NoAcceptableStepReturnsFalseAfterTheAttemptsAtTheDampingLimit) {
  const Quadratic q = some_quadratic();
  LevenbergMarquardtSettings settings;
  settings.initial_lambda = 1e-3;
  settings.max_lambda = 1.0;
  settings.max_attempts = 6;
  LevenbergMarquardt lm(settings);
  Vector3 delta;
  const auto never = [](const Vector3&) { return std::numeric_limits<double>::infinity(); };
  EXPECT_FALSE(lm.step(q.H, q.g, q.c, never, delta));
  EXPECT_EQ(lm.num_rejected(), 6);
  EXPECT_DOUBLE_EQ(lm.lambda(), 1.0);  // 1e-3 grown tenfold three times, then held at max_lambda
  EXPECT_TRUE(lm.at_max_lambda());
  // A tiny damping grows to at least 1e-8 on the first rejection.
  settings.initial_lambda = 1e-12;
  settings.max_lambda = 1e12;
  settings.max_attempts = 1;
  LevenbergMarquardt tiny(settings);
  EXPECT_FALSE(tiny.step(q.H, q.g, q.c, never, delta));
  EXPECT_DOUBLE_EQ(tiny.lambda(), 1e-8);
}

TEST(LevenbergMarquardtTest, ANonFiniteSystemGivesNoStep) {
  Quadratic q = some_quadratic();
  q.g(1) = std::numeric_limits<double>::quiet_NaN();
  LevenbergMarquardt lm;
  Vector3 delta;
  int evaluations = 0;
  EXPECT_FALSE(lm.step(q.H, q.g, q.c, [&](const Vector3&) { return ++evaluations, 0.0; }, delta));
  EXPECT_EQ(evaluations, 0);
}

TEST(LevenbergMarquardtTest, DynamicSizedSystemsTakeTheSameStep) {
  const Quadratic q = some_quadratic();
  const Eigen::MatrixXd H = q.H;
  const Eigen::VectorXd g = q.g;
  LevenbergMarquardt fixed, dynamic;
  Vector3 d3;
  Eigen::VectorXd dx;
  ASSERT_TRUE(fixed.step(q.H, q.g, q.c, q, d3));
  ASSERT_TRUE(dynamic.step(H, g, q.c, [&](const Eigen::VectorXd& d) { return q(Vector3(d)); }, dx));
  ASSERT_EQ(dx.size(), 3);
  EXPECT_LT((Vector3(dx) - d3).norm(), 1e-14);
}

TEST(LevenbergMarquardtTest, LinearisingLoopReachesTheMinimumOfRosenbrock) {
  // f(x, y) = 1/2 (r1^2 + r2^2), r1 = 10 (y - x^2), r2 = 1 - x: minimum 0 at (1, 1); the classic
  // start (-1.2, 1) makes Gauss-Newton's first step overshoot far up the valley.
  Eigen::Vector2d x(-1.2, 1.0);
  const auto cost = [](const Eigen::Vector2d& p) {
    const double r1 = 10.0 * (p.y() - p.x() * p.x()), r2 = 1.0 - p.x();
    return 0.5 * (r1 * r1 + r2 * r2);
  };
  LevenbergMarquardt lm;
  for (int it = 0; it < 100 && cost(x) > 1e-24; ++it) {
    Eigen::Matrix2d J;
    J << -20.0 * x.x(), 10.0, -1.0, 0.0;
    const Eigen::Vector2d r(10.0 * (x.y() - x.x() * x.x()), 1.0 - x.x());
    const Eigen::Matrix2d H = J.transpose() * J;
    const Eigen::Vector2d g = J.transpose() * r;
    Eigen::Vector2d delta;
    if (!lm.step(H, g, cost(x), [&](const Eigen::Vector2d& d) { return cost(x + d); }, delta)) break;
    x += delta;
  }
  EXPECT_NEAR(x.x(), 1.0, 1e-9);
  EXPECT_NEAR(x.y(), 1.0, 1e-9);
}

TEST(LevenbergMarquardtTest, InvalidSettingsThrow) {
  LevenbergMarquardtSettings s;
  s.initial_lambda = -1.0;
  EXPECT_THROW(LevenbergMarquardt{s}, Error);
  s = {};
  s.initial_lambda = 10.0;
  s.max_lambda = 1.0;
  EXPECT_THROW(LevenbergMarquardt{s}, Error);
  s = {};
  s.max_lambda = std::numeric_limits<double>::infinity();
  EXPECT_THROW(LevenbergMarquardt{s}, Error);
  s = {};
  s.max_attempts = 0;
  EXPECT_THROW(LevenbergMarquardt{s}, Error);
}

}  // namespace
}  // namespace plumb
