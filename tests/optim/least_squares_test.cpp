// SPDX-License-Identifier: BSD-3-Clause
// The manifold least-squares solver on problems with known answers: pose fitting and rotation
// averaging on SO(3), the extended Rosenbrock function, a problem where Gauss-Newton diverges and
// LM does not, a line fit with 30 % gross outliers, and bad input.
#include <cmath>
#include <limits>
#include <vector>

#include <gtest/gtest.h>

#include "plumb/core/error.hpp"
#include "plumb/core/lie.hpp"
#include "plumb/core/rng.hpp"
#include "plumb/optim/least_squares.hpp"

namespace plumb {
namespace {

using Vec1 = Eigen::Matrix<double, 1, 1>;
using Jac1 = Eigen::Matrix<double, 1, Eigen::Dynamic>;
using Vec2 = Eigen::Matrix<double, 2, 1>;
using Jac2 = Eigen::Matrix<double, 2, Eigen::Dynamic>;
using Vec3 = Eigen::Matrix<double, 3, 1>;
using Jac3 = Eigen::Matrix<double, 3, Eigen::Dynamic>;

Vector3d normal3(Rng& rng, double sigma = 1.0) {
  const double x = rng.normal(), y = rng.normal(), z = rng.normal();
  return sigma * Vector3d(x, y, z);
}

double rotation_distance(const Matrix3d& a, const Matrix3d& b) { return so3::log(a.transpose() * b).norm(); }

// Points q = R p + t: residual R p + t - q, Jacobians -R hat(p) (right perturbation) and I.
void add_point_pairs(LeastSquaresProblem& problem, int R, int t, const std::vector<Vector3d>& p,
                     const std::vector<Vector3d>& q) {
  for (std::size_t k = 0; k < p.size(); ++k) {
    problem.add_residual<3>({R, t}, [R, t, pk = p[k], qk = q[k]](const ManifoldValues& x, Vec3& r, Jac3* J) {
      const Matrix3d& Rv = x.rotation(R);
      r = Rv * pk + x.vector<3>(t) - qk;
      if (J != nullptr) {
        J->leftCols<3>() = -Rv * hat(pk);
        J->rightCols<3>().setIdentity();
      }
    });
  }
}

TEST(LeastSquaresTest, PoseFittingRecoversKnownTransformFromFarStarts) {
  Rng rng(1);
  const Matrix3d R_true = so3::exp(Vector3d(0.3, -2.0, 1.2));  // 2.4 rad
  const Vector3d t_true(1.0, -2.0, 0.5);
  std::vector<Vector3d> p, q;
  for (int k = 0; k < 30; ++k) {
    p.push_back(normal3(rng, 2.0));
    q.push_back(R_true * p.back() + t_true);
  }
  for (auto method : {LeastSquaresMethod::kGaussNewton, LeastSquaresMethod::kLevenbergMarquardt}) {
    for (const Vector3d& start : {Vector3d(0, 0, 0), Vector3d(2.5, 0.5, -1.0), Vector3d(-1.0, 2.0, 1.5)}) {
      LeastSquaresProblem problem;
      const int R = problem.add_rotation(so3::exp(start));
      const int t = problem.add_vector(Vector3d(10.0, 0.0, 0.0));
      add_point_pairs(problem, R, t, p, q);
      EXPECT_LT(problem.max_jacobian_error(), 1e-6);
      LeastSquaresSettings settings;
      settings.method = method;
      const LeastSquaresResult result = solve_least_squares(problem, settings);
      EXPECT_TRUE(result.converged) << "start " << start.transpose();
      EXPECT_EQ(result.status, Status::kOk);
      EXPECT_GT(result.initial_cost, 1.0);
      EXPECT_LT(result.final_cost, 1e-20);
      EXPECT_LT(rotation_distance(problem.values().rotation(R), R_true), 1e-9);
      EXPECT_LT((problem.values().vector<3>(t) - t_true).norm(), 1e-9);
      EXPECT_LT(result.iterations, 30);
      EXPECT_EQ(result.information.rows(), 6);
    }
  }
}

TEST(LeastSquaresTest, RotationAveragingWithSymmetricNoiseRecoversTheMean) {
  // Measurements R* exp(+e_k) and R* exp(-e_k): sum_k log(R*^T R_k) = 0, so R* is the geodesic
  // L2 mean. Residual log(R_k^T R), Jacobian J_r^-1(r).
  Rng rng(2);
  const Matrix3d R_true = so3::exp(Vector3d(-0.7, 0.4, 2.2));
  LeastSquaresProblem problem;
  const int R = problem.add_rotation(R_true * so3::exp(Vector3d(0.6, -0.5, 0.4)));
  for (int k = 0; k < 10; ++k) {
    const Vector3d e = normal3(rng, 0.3);
    for (const Matrix3d& Rk : {Matrix3d(R_true * so3::exp(e)), Matrix3d(R_true * so3::exp(-e))}) {
      problem.add_residual<3>({R}, [R, Rk](const ManifoldValues& x, Vec3& r, Jac3* J) {
        r = so3::log(Rk.transpose() * x.rotation(R));
        if (J != nullptr) *J = so3::right_jacobian_inverse(r);
      });
    }
  }
  EXPECT_LT(problem.max_jacobian_error(), 1e-6);
  // At a minimum with a nonzero cost a relative cost change f means an error ~ sqrt(f) in the
  // argument: ask for 1e-9 in the rotation by stopping on the step or gradient only.
  LeastSquaresSettings settings;
  settings.function_tolerance = 1e-16;
  const LeastSquaresResult result = solve_least_squares(problem, settings);
  EXPECT_TRUE(result.converged);
  EXPECT_LT(rotation_distance(problem.values().rotation(R), R_true), 1e-9);
  // The cost at the optimum is the known sum of squared noise angles (nothing absorbs them).
  EXPECT_GT(result.final_cost, 0.1);
}

// Extended Rosenbrock (Moré, Garbow, Hillstrom 1981, problem 21): r = 10 (x2 - x1^2), 1 - x1 per pair.
TEST(LeastSquaresTest, ExtendedRosenbrockReachesTheMinimum) {
  LeastSquaresProblem problem;
  std::vector<int> blocks;
  for (int k = 0; k < 5; ++k) {
    const int b = problem.add_vector(Eigen::Vector2d(-1.2, 1.0));
    blocks.push_back(b);
    problem.add_residual<2>({b}, [b](const ManifoldValues& x, Vec2& r, Jac2* J) {
      const auto v = x.vector<2>(b);
      r << 10.0 * (v(1) - v(0) * v(0)), 1.0 - v(0);
      if (J != nullptr) *J << -20.0 * v(0), 10.0, -1.0, 0.0;
    });
  }
  // Couple neighbouring pairs weakly so the problem is not separable: r = 0.1 (x_k,2 - x_{k+1},1).
  for (int k = 0; k + 1 < 5; ++k) {
    const int a = blocks[static_cast<std::size_t>(k)], b = blocks[static_cast<std::size_t>(k + 1)];
    problem.add_residual<1>({a, b}, [a, b](const ManifoldValues& x, Vec1& r, Jac1* J) {
      r(0) = 0.1 * (x.vector<2>(a)(1) - x.vector<2>(b)(0));
      if (J != nullptr) *J << 0.0, 0.1, -0.1, 0.0;
    });
  }
  EXPECT_LT(problem.max_jacobian_error(), 1e-6);
  const LeastSquaresResult result = solve_least_squares(problem);
  EXPECT_TRUE(result.converged);
  EXPECT_EQ(result.status, Status::kOk);
  for (int b : blocks) EXPECT_LT((problem.values().vector<2>(b) - Eigen::Vector2d(1.0, 1.0)).norm(), 1e-8);
  EXPECT_LT(result.final_cost, 1e-18);
}

// r(x) = [x + 1, l x^2 + x - 1] (Madsen, Nielsen, Tingleff 2004, example 3.2): x* = 0 with a
// nonzero residual; near it Gauss-Newton maps x to about l x, so it diverges for |l| > 1, while
// x* is still the minimum for l < 1 (F''(0) = 2 - 2 l).
LeastSquaresProblem madsen_problem(double l, double x0, int* block) {
  LeastSquaresProblem problem;
  const int b = problem.add_vector(Eigen::VectorXd::Constant(1, x0));
  problem.add_residual<2>({b}, [b, l](const ManifoldValues& x, Vec2& r, Jac2* J) {
    const double v = x.vector<1>(b)(0);
    r << v + 1.0, l * v * v + v - 1.0;
    if (J != nullptr) *J << 1.0, 2.0 * l * v + 1.0;
  });
  *block = b;
  return problem;
}

TEST(LeastSquaresTest, LevenbergMarquardtConvergesWhereGaussNewtonDiverges) {
  for (double x0 : {0.05, 1.0, -3.0}) {
    int b = 0;
    LeastSquaresProblem gn_problem = madsen_problem(-2.0, x0, &b);
    LeastSquaresSettings gn;
    gn.method = LeastSquaresMethod::kGaussNewton;
    const LeastSquaresResult gn_result = solve_least_squares(gn_problem, gn);
    EXPECT_FALSE(gn_result.converged) << "x0 " << x0;
    EXPECT_GT(std::abs(gn_problem.values().vector<1>(b)(0)), 1e-3) << "x0 " << x0;

    LeastSquaresProblem lm_problem = madsen_problem(-2.0, x0, &b);
    LeastSquaresSettings lm;
    lm.function_tolerance = 1e-14;  // a nonzero residual at the minimum: error ~ sqrt(tolerance)
    const LeastSquaresResult lm_result = solve_least_squares(lm_problem, lm);
    EXPECT_TRUE(lm_result.converged) << "x0 " << x0;
    EXPECT_LT(std::abs(lm_problem.values().vector<1>(b)(0)), 1e-6) << "x0 " << x0;
    EXPECT_NEAR(lm_result.final_cost, 1.0, 1e-10);  // F(0) = (1 + 1) / 2
    EXPECT_LE(lm_result.final_cost, lm_result.initial_cost);
  }
  // With |l| < 1 Gauss-Newton converges too.
  int b = 0;
  LeastSquaresProblem easy = madsen_problem(0.5, 1.0, &b);
  LeastSquaresSettings gn;
  gn.method = LeastSquaresMethod::kGaussNewton;
  gn.function_tolerance = 1e-16;  // linear convergence at a nonzero residual: stop on the step
  gn.max_iterations = 100;
  EXPECT_TRUE(solve_least_squares(easy, gn).converged);
  EXPECT_LT(std::abs(easy.values().vector<1>(b)(0)), 1e-6);
}

struct LineData {
  std::vector<double> x, y;
};

// y = 2 x + 1 with 0.05 noise; 30 % of the points pushed up by 5..20 (gross, one-sided outliers).
LineData line_with_outliers() {
  Rng rng(3);
  LineData d;
  for (int k = 0; k < 100; ++k) {
    const double x = rng.uniform(0.0, 10.0);
    double y = 2.0 * x + 1.0 + rng.normal(0.0, 0.05);
    if (k % 10 < 3) y += rng.uniform(5.0, 20.0);
    d.x.push_back(x);
    d.y.push_back(y);
  }
  return d;
}

Eigen::Vector2d fit_line(const LineData& d, const RobustLoss& loss, const Eigen::Vector2d& start) {
  LeastSquaresProblem problem;
  const int ab = problem.add_vector(start);
  for (std::size_t k = 0; k < d.x.size(); ++k) {
    problem.add_residual<1>({ab}, [ab, xk = d.x[k], yk = d.y[k]](const ManifoldValues& v, Vec1& r, Jac1* J) {
      const auto p = v.vector<2>(ab);
      r(0) = p(0) * xk + p(1) - yk;
      if (J != nullptr) *J << xk, 1.0;
    }, loss);
  }
  LeastSquaresSettings settings;
  settings.max_iterations = 100;
  const LeastSquaresResult result = solve_least_squares(problem, settings);
  EXPECT_TRUE(result.converged);
  return problem.values().vector<2>(ab);
}

TEST(LeastSquaresTest, RobustLossesRecoverALineWithThirtyPercentOutliers) {
  const LineData d = line_with_outliers();
  const Eigen::Vector2d truth(2.0, 1.0);
  const Eigen::Vector2d plain = fit_line(d, RobustLoss::none(), Eigen::Vector2d::Zero());
  const Eigen::Vector2d huber = fit_line(d, RobustLoss::huber(0.1), Eigen::Vector2d::Zero());
  const Eigen::Vector2d cauchy = fit_line(d, RobustLoss::cauchy(0.1), Eigen::Vector2d::Zero());
  EXPECT_GT((plain - truth).norm(), 1.0);  // least squares is dragged up by the outliers
  // Huber bounds each outlier's pull to the scale: 30 outliers x 0.1 against 70 inliers.
  EXPECT_LT((huber - truth).norm(), 0.1);
  EXPECT_LT((cauchy - truth).norm(), 0.03);  // Cauchy all but ignores them
}

TEST(LeastSquaresTest, ConstantBlocksStayAndFreeBlocksMove) {
  Rng rng(4);
  const Matrix3d R_true = so3::exp(Vector3d(0.2, 0.1, -0.4));
  const Vector3d t_true(0.3, 0.2, 0.1);
  std::vector<Vector3d> p, q;
  for (int k = 0; k < 10; ++k) {
    p.push_back(normal3(rng));
    q.push_back(R_true * p.back() + t_true);
  }
  LeastSquaresProblem problem;
  const int R = problem.add_rotation(Matrix3d::Identity());
  const int t = problem.add_vector(t_true, /*constant=*/true);
  add_point_pairs(problem, R, t, p, q);
  EXPECT_EQ(problem.num_free_parameters(), 3);
  const LeastSquaresResult result = solve_least_squares(problem);
  EXPECT_TRUE(result.converged);
  EXPECT_EQ(problem.values().vector<3>(t), t_true);  // untouched, bit for bit
  EXPECT_LT(rotation_distance(problem.values().rotation(R), R_true), 1e-9);
  EXPECT_EQ(result.information.rows(), 3);
  // All blocks constant: nothing to solve, the cost is reported.
  problem.set_constant(R, true);
  const LeastSquaresResult none = solve_least_squares(problem);
  EXPECT_EQ(none.iterations, 0);
  EXPECT_NEAR(none.final_cost, problem.cost(), 1e-15);
}

TEST(LeastSquaresTest, GaussNewtonReportsADegenerateProblem) {
  // The residual ignores the second coordinate: J^T J is singular.
  LeastSquaresProblem problem;
  const int b = problem.add_vector(Eigen::Vector2d(3.0, 4.0));
  problem.add_residual<1>({b}, [b](const ManifoldValues& x, Vec1& r, Jac1* J) {
    r(0) = x.vector<2>(b)(0) - 1.0;
    if (J != nullptr) *J << 1.0, 0.0;
  });
  LeastSquaresSettings gn;
  gn.method = LeastSquaresMethod::kGaussNewton;
  EXPECT_EQ(solve_least_squares(problem, gn).status, Status::kDegenerate);
  // LM's damping handles it: the constrained coordinate is solved, the other one stays.
  const LeastSquaresResult lm = solve_least_squares(problem);
  EXPECT_TRUE(lm.converged);
  EXPECT_NEAR(problem.values().vector<2>(b)(0), 1.0, 1e-8);
  EXPECT_NEAR(problem.values().vector<2>(b)(1), 4.0, 1e-8);
}

TEST(LeastSquaresTest, BadInputThrowsOrReportsAStatus) {
  LeastSquaresProblem problem;
  const int R = problem.add_rotation(Matrix3d::Identity());
  const int v = problem.add_vector(Eigen::Vector2d(1.0, 2.0));
  auto f = [](const ManifoldValues&, Vec1& r, Jac1*) { r(0) = 0.0; };
  EXPECT_THROW(problem.add_residual<1>({7}, f), Error);
  EXPECT_THROW(problem.add_residual<1>({R, R}, f), Error);
  EXPECT_THROW(problem.add_residual<1>({}, f), Error);
  EXPECT_THROW(problem.add_rotation(2.0 * Matrix3d::Identity()), Error);
  EXPECT_THROW(problem.add_rotation(-Matrix3d::Identity()), Error);
  EXPECT_THROW(problem.add_vector(Eigen::VectorXd()), Error);
  EXPECT_THROW(problem.add_vector(Eigen::Vector2d(std::nan(""), 0.0)), Error);
  EXPECT_THROW(problem.values().vector<3>(v), Error);
  EXPECT_THROW(problem.values().rotation(v), Error);
  EXPECT_THROW(problem.values().vector(R), Error);
  EXPECT_THROW(problem.set_constant(9, true), Error);
  EXPECT_THROW(RobustLoss::huber(0.0), Error);
  EXPECT_THROW(RobustLoss::cauchy(-1.0), Error);
  LeastSquaresSettings bad;
  bad.initial_lambda = 0.0;
  EXPECT_THROW(solve_least_squares(problem, bad), Error);
  // A residual that is not finite at the start: a status, values untouched.
  problem.add_residual<1>({v}, [v](const ManifoldValues& x, Vec1& r, Jac1* J) {
    r(0) = std::log(x.vector<2>(v)(0) - 5.0);  // NaN at the start
    if (J != nullptr) *J << 1.0 / (x.vector<2>(v)(0) - 5.0), 0.0;
  });
  const LeastSquaresResult result = solve_least_squares(problem);
  EXPECT_EQ(result.status, Status::kInvalidInput);
  EXPECT_FALSE(result.converged);
  EXPECT_EQ(problem.values().vector<2>(v), Eigen::Vector2d(1.0, 2.0));
}

}  // namespace
}  // namespace plumb
