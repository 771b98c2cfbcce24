// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/sim/wheel_model.hpp"

#include <cmath>

#include <gtest/gtest.h>

#include "plumb/core/error.hpp"

namespace plumb::sim {
namespace {

RobotTrajectory wheel_loop_trajectory() {
  return drive_route({{0, 0}, {6, 0}, {6, 3}, {4, 3}, {3, 1.5}, {2, 3}, {0, 3}}, true, 2, 0.0, 0.0);
}

TEST(WheelTest, ZeroNoiseOdometryIntegratesToGroundTruth) {
  const RobotTrajectory traj = wheel_loop_trajectory();
  WheelSettings s;
  s.radius_error_left = s.radius_error_right = s.axle_error = s.slip_sigma = 0.0;
  const auto wheels = simulate_wheels(traj, s);
  const Pose2 start = traj.states.front().pose;
  const auto odom = integrate_wheel_odometry(wheels, s.radius, s.radius, s.axle, start);
  ASSERT_EQ(odom.size(), wheels.size());
  double max_err = 0.0, max_dtheta = 0.0;
  for (const OdomSample& o : odom) {
    const RobotState truth = traj.state_at(o.stamp);
    max_err = std::max(max_err, std::hypot(o.pose.x - truth.pose.x, o.pose.y - truth.pose.y));
    max_dtheta = std::max(max_dtheta, std::abs(o.pose.theta - truth.pose.theta));
  }
  EXPECT_GT(traj.length(), 35.0);
  EXPECT_LT(max_err, 1e-5 * traj.length());  // arc-per-interval integration of a non-constant curvature
  EXPECT_LT(max_dtheta, 1e-9);
  EXPECT_NEAR(wheels.back().stamp, traj.end_time(), 1.0 / s.rate_hz);
}

TEST(WheelTest, RadiusErrorScalesTheOdometry) {
  // Straight 8 m: the wheels turn by distance / true radius; nominal integration scales by 1 / (1 + e).
  const RobotTrajectory traj = drive_route({{0, 0}, {8, 0}}, false, 1, 0.0, 0.0);
  WheelSettings s;
  s.radius_error_left = s.radius_error_right = 0.01;
  s.slip_sigma = 0.0;
  const auto odom = integrate_wheel_odometry(simulate_wheels(traj, s), s.radius, s.radius, s.axle);
  const double true_distance = traj.state_at(odom.back().stamp).s;
  EXPECT_GT(true_distance, 7.9);
  EXPECT_NEAR(odom.back().pose.x, true_distance / 1.01, 1e-9);
  EXPECT_NEAR(odom.back().pose.theta, 0.0, 1e-12);
  // Unequal radii make the straight drive curve in the odometry: dtheta = (dr - dl) / axle.
  s.radius_error_left = 0.005;
  s.radius_error_right = -0.005;
  const auto curved = integrate_wheel_odometry(simulate_wheels(traj, s), s.radius, s.radius, s.axle);
  const double expected_theta = true_distance * (1 / 0.995 - 1 / 1.005) / s.axle;
  EXPECT_NEAR(curved.back().pose.theta, expected_theta, 1e-9);
}

TEST(WheelTest, DefaultErrorsAndSlipDriftButStayPlausible) {
  const RobotTrajectory traj = wheel_loop_trajectory();
  const WheelSettings s;
  const auto wheels = simulate_wheels(traj, s);
  const auto odom = integrate_wheel_odometry(wheels, s.radius, s.radius, s.axle, traj.states.front().pose);
  const RobotState end = traj.states.back();
  const double err = std::hypot(odom.back().pose.x - end.pose.x, odom.back().pose.y - end.pose.y);
  EXPECT_GT(err, 0.01);                    // the errors do show
  EXPECT_LT(err, 0.1 * traj.length());     // but this is still odometry
  // Determinism for a seed, different noise for another seed.
  const auto again = simulate_wheels(traj, s);
  EXPECT_EQ(again.back().left, wheels.back().left);
  WheelSettings other = s;
  other.seed = 2;
  EXPECT_NE(simulate_wheels(traj, other).back().left, wheels.back().left);
}

TEST(WheelTest, BadParametersThrow) {
  const RobotTrajectory traj = drive_route({{0, 0}, {1, 0}}, false, 1, 0.0, 0.0);
  WheelSettings s;
  s.radius = 0.0;
  EXPECT_THROW(simulate_wheels(traj, s), Error);
  EXPECT_THROW(simulate_wheels(RobotTrajectory{}, WheelSettings{}), Error);
  EXPECT_THROW(integrate_wheel_odometry({}, 0.1, 0.1, 0.0), Error);
  EXPECT_THROW(integrate_wheel_odometry({{1.0, 0, 0}, {1.0, 1, 1}}, 0.1, 0.1, 0.5), Error);
}

}  // namespace
}  // namespace plumb::sim
