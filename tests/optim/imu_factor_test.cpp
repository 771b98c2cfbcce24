// SPDX-License-Identifier: BSD-3-Clause
// The IMU factor inside the least-squares solver: Jacobians through the problem's retraction, and
// solving for state j from state i and the IMU alone recovers the prediction; with both poses and
// velocities known, the solver recovers the biases hidden in the measurements.
#include <vector>

#include <gtest/gtest.h>

#include "plumb/core/lie.hpp"
#include "plumb/core/rng.hpp"
#include "plumb/imu/preintegration.hpp"
#include "plumb/optim/imu_factor.hpp"
#include "plumb/optim/least_squares.hpp"

namespace plumb {
namespace {

ImuPreintegration moving_body(const ImuBias& bias_hat, std::uint64_t seed) {
  Rng rng(seed);
  ImuPreintegration pim(bias_hat);
  Vector3d w(0.2, -0.1, 0.5), a(0.3, 0.1, 9.8);
  for (int k = 0; k < 40; ++k) {  // 0.2 s at 200 Hz
    w += 0.02 * Vector3d(rng.normal(), rng.normal(), rng.normal());
    a += 0.1 * Vector3d(rng.normal(), rng.normal(), rng.normal());
    pim.add_measurement(w, a, 0.005);
  }
  return pim;
}

TEST(ImuFactorTest, JacobiansMatchNumericThroughTheProblem) {
  ImuBias bhat;
  bhat.gyro = Vector3d(0.01, 0.0, -0.01);
  const ImuPreintegration pim = moving_body(bhat, 1);
  ImuState xi;
  xi.R_world_body = so3::exp(Vector3d(0.2, 0.1, 1.0));
  xi.v_world = Vector3d(1.0, 0.0, 0.1);
  xi.bias = bhat;
  xi.bias.accel = Vector3d(0.02, -0.01, 0.03);
  Vector15d d;
  for (int k = 0; k < 15; ++k) d(k) = 0.03 * ((k % 3) - 1.0);
  const ImuState xj = retract(pim.predict(xi), d);
  LeastSquaresProblem problem;
  const ImuStateBlocks bi = add_imu_state(problem, xi), bj = add_imu_state(problem, xj);
  add_imu_factor(problem, pim, bi, bj);
  EXPECT_GT(problem.cost(), 1.0);
  // The whitened factor's Jacobian against central differences (relative to its norm).
  EXPECT_LT(problem.max_jacobian_error(1e-6), 1e-6);
}

TEST(ImuFactorTest, SolvingForStateJRecoversThePrediction) {
  const ImuPreintegration pim = moving_body({}, 2);
  ImuState xi;
  xi.R_world_body = so3::exp(Vector3d(-0.3, 0.2, 2.0));
  xi.p_world_body = Vector3d(5.0, -2.0, 1.0);
  xi.v_world = Vector3d(0.5, 1.0, 0.0);
  const ImuState expected = pim.predict(xi);
  LeastSquaresProblem problem;
  const ImuStateBlocks bi = add_imu_state(problem, xi, /*constant=*/true);
  ImuState start;  // far off: identity, zero velocity, biases off
  start.bias.gyro = Vector3d(0.01, 0.02, -0.01);
  const ImuStateBlocks bj = add_imu_state(problem, start);
  add_imu_factor(problem, pim, bi, bj);
  LeastSquaresSettings settings;
  settings.function_tolerance = 0.0;
  const LeastSquaresResult result = solve_least_squares(problem, settings);
  EXPECT_TRUE(result.converged);
  EXPECT_LT(result.final_cost, 1e-12);
  const ImuState xj = imu_state(problem.values(), bj);
  EXPECT_LT(so3::log(xj.R_world_body.transpose() * expected.R_world_body).norm(), 1e-9);
  EXPECT_LT((xj.p_world_body - expected.p_world_body).norm(), 1e-9);
  EXPECT_LT((xj.v_world - expected.v_world).norm(), 1e-9);
  EXPECT_LT((xj.bias.gyro - xi.bias.gyro).norm(), 1e-9);
  // State i untouched.
  EXPECT_EQ(imu_state(problem.values(), bi).p_world_body, xi.p_world_body);
}

TEST(ImuFactorTest, KnownStatesRevealTheBiases) {
  // Measurements of a moving body plus constant biases, preintegrated at bias 0; the true states at
  // both ends are known (constant blocks), only the biases are free.
  Rng rng(3);
  ImuBias truth;
  truth.gyro = Vector3d(0.01, -0.02, 0.015);
  truth.accel = Vector3d(0.05, -0.03, 0.02);
  ImuPreintegration clean, biased;
  Vector3d w(0.3, -0.2, 0.8), a(0.5, 0.2, 9.8);
  for (int k = 0; k < 200; ++k) {  // 1 s at 200 Hz, turning about all axes
    w += 0.05 * Vector3d(rng.normal(), rng.normal(), rng.normal());
    a += 0.3 * Vector3d(rng.normal(), rng.normal(), rng.normal());
    clean.add_measurement(w, a, 0.005);
    biased.add_measurement(w + truth.gyro, a + truth.accel, 0.005);
  }
  ImuState xi;
  xi.v_world = Vector3d(1.0, 0.0, 0.0);
  const ImuState xj = clean.predict(xi);
  LeastSquaresProblem problem;
  const ImuStateBlocks bi = add_imu_state(problem, xi, true), bj = add_imu_state(problem, xj, true);
  for (int b : {bi.bg, bi.ba, bj.bg, bj.ba}) problem.set_constant(b, false);
  add_imu_factor(problem, biased, bi, bj);
  const LeastSquaresResult result = solve_least_squares(problem);
  EXPECT_TRUE(result.converged);
  const ImuState est = imu_state(problem.values(), bi);
  // First-order bias correction: what is left is second order in the bias (~1e-4 here).
  EXPECT_LT((est.bias.gyro - truth.gyro).norm(), 0.05 * truth.gyro.norm());
  EXPECT_LT((est.bias.accel - truth.accel).norm(), 0.05 * truth.accel.norm());
  EXPECT_LT((imu_state(problem.values(), bj).bias.gyro - est.bias.gyro).norm(), 1e-6);
}

}  // namespace
}  // namespace plumb
