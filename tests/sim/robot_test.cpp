// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/sim/robot.hpp"

#include <cmath>

#include <gtest/gtest.h>

#include "plumb/core/error.hpp"

namespace plumb::sim {
namespace {

/// A rectangle 6 x 3 m with a zig-zag on one side (sharp corners and a U-turn).
std::vector<Vector2d> test_path() {
  return {{0, 0}, {6, 0}, {6, 3}, {4, 3}, {3, 1.5}, {2, 3}, {0, 3}};
}

TEST(RobotTest, RespectsLimitsAndHasContinuousAcceleration) {
  RobotSettings s;
  const RobotTrajectory traj = drive_route(test_path(), true, 2, 0.0, 0.0, s);
  ASSERT_GT(traj.states.size(), 1000u);
  const double dt = 1.0 / s.rate_hz;
  for (std::size_t k = 0; k < traj.states.size(); ++k) {
    const RobotState& st = traj.states[k];
    ASSERT_LE(std::abs(st.v), s.max_speed + 1e-9) << k;
    ASSERT_LE(std::abs(st.w), s.max_turn_rate + 1e-9) << k;
    ASSERT_LE(std::abs(st.a), s.max_acceleration + 1e-9) << k;
    ASSERT_LE(std::abs(st.alpha), s.max_angular_acceleration + 1e-9) << k;
    if (k == 0) continue;
    const RobotState& p = traj.states[k - 1];
    ASSERT_NEAR(st.t - p.t, dt, 1e-9);
    ASSERT_LE(std::abs(st.a - p.a), s.max_jerk * dt + 1e-12) << k;  // continuous acceleration
    ASSERT_LE(std::abs(st.alpha - p.alpha), s.max_angular_jerk * dt + 1e-12) << k;
  }
  // Standing still at the start (for IMU initialisation), then arriving back at the start.
  EXPECT_EQ(traj.state_at(traj.start_time() + 0.9).v, 0.0);
  const RobotState& last = traj.states.back();
  EXPECT_LT((Vector2d(last.pose.x, last.pose.y)).norm(), 0.15);
  EXPECT_LT(std::abs(last.v), 1e-3);
  const double loop = 6 + 3 + 2 + std::hypot(1, 1.5) * 2 + 2 + 3;
  EXPECT_NEAR(traj.length(), 2 * loop, 0.1 * loop);
}

TEST(RobotTest, StatesAreSelfConsistent) {
  const RobotTrajectory traj = drive_route(test_path(), true, 1, 0.0, 0.7);
  // Finite differences of the pose agree with the speeds, and of the speeds with the accelerations.
  const double h = 1e-4;
  for (double t = 1.2; t < traj.end_time() - 1.0; t += 0.731) {
    const RobotState a = traj.state_at(t - h), b = traj.state_at(t + h), c = traj.state_at(t);
    const Vector2d vel((b.pose.x - a.pose.x) / (2 * h), (b.pose.y - a.pose.y) / (2 * h));
    EXPECT_NEAR(vel.x(), c.v * std::cos(c.pose.theta), 1e-6) << t;
    EXPECT_NEAR(vel.y(), c.v * std::sin(c.pose.theta), 1e-6) << t;
    EXPECT_NEAR((b.pose.theta - a.pose.theta) / (2 * h), c.w, 1e-6) << t;
    EXPECT_NEAR((b.v - a.v) / (2 * h), c.a, 2e-4) << t;  // jerk steps at step ends
    EXPECT_NEAR((b.w - a.w) / (2 * h), c.alpha, 1e-3) << t;
    EXPECT_NEAR((b.s - a.s) / (2 * h), c.v, 1e-6) << t;
  }
  // state_at reproduces the stored states at their stamps.
  for (std::size_t k = 0; k + 1 < traj.states.size(); k += 997) {
    const RobotState s = traj.state_at(traj.states[k].t);
    EXPECT_NEAR(s.pose.x, traj.states[k].pose.x, 1e-12);
    EXPECT_NEAR(s.pose.theta, traj.states[k].pose.theta, 1e-12);
  }
  const Eigen::Isometry3d T = traj.T_world_base(5.0);
  EXPECT_EQ(T.translation().z(), 0.7);
  EXPECT_NEAR(T.linear()(2, 2), 1.0, 1e-15);
}

TEST(RobotTest, MaxLengthAndDeterminism) {
  const RobotTrajectory a = drive_route(test_path(), true, 3, 10.0, 0.0);
  EXPECT_NEAR(a.length(), 10.0, 0.5);  // 10 m along the route; corners are cut a little
  const RobotTrajectory b = drive_route(test_path(), true, 3, 10.0, 0.0);
  ASSERT_EQ(a.states.size(), b.states.size());
  EXPECT_EQ(a.states.back().pose.x, b.states.back().pose.x);
  const RobotTrajectory open = drive_route({{0, 0}, {5, 0}}, false, 1, 0.0, 0.0);
  EXPECT_NEAR(open.states.back().pose.x, 5.0, 0.06);
  EXPECT_NEAR(open.states.back().pose.y, 0.0, 1e-9);
}

TEST(RobotTest, BadArgumentsThrow) {
  EXPECT_THROW(drive_route({{0, 0}}, true, 1, 0.0, 0.0), Error);
  EXPECT_THROW(drive_route(test_path(), true, 0, 0.0, 0.0), Error);
  EXPECT_THROW(drive_route({{0, 0}, {0, 0}}, false, 1, 0.0, 0.0), Error);
  RobotSettings s;
  s.max_speed = 0.0;
  EXPECT_THROW(drive_route(test_path(), true, 1, 0.0, 0.0, s), Error);
  RobotTrajectory empty;
  EXPECT_THROW(empty.state_at(0.0), Error);
}

}  // namespace
}  // namespace plumb::sim
