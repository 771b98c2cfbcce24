// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief A differential-drive robot driving a route: pure pursuit on the polyline, speed,
///        turn-rate, acceleration and jerk limits, so that acceleration is continuous (the IMU
///        model differentiates nothing: it reads the acceleration of the state).

#include <vector>

#include <Eigen/Geometry>

#include "plumb/core/pose2.hpp"
#include "plumb/core/types.hpp"

namespace plumb::sim {

/// @brief Settings of drive_route().
struct RobotSettings {
  double max_speed = 0.8;                 ///< forward speed limit [m/s]
  double max_turn_rate = 0.8;             ///< |yaw rate| limit [rad/s]
  double max_acceleration = 0.5;          ///< |dv/dt| limit [m/s^2]
  double max_angular_acceleration = 1.5;  ///< |dw/dt| limit [rad/s^2]
  double max_jerk = 2.0;                  ///< |d^2v/dt^2| limit [m/s^3]
  double max_angular_jerk = 8.0;          ///< |d^2w/dt^2| limit [rad/s^3]
  double max_lateral_acceleration = 0.4;  ///< v * |w| limit in curves [m/s^2]
  double lookahead = 0.6;                 ///< pure-pursuit lookahead distance [m]
  double rate_hz = 1000.0;                ///< integration (and dense ground-truth) rate [Hz]
  double start_time = 0.0;                ///< time of the first state [s]
  double still_before = 1.0;              ///< standing still before driving off [s]
  double still_after = 0.5;               ///< standing still after stopping [s]
  double max_duration = 7200.0;           ///< give up (plumb::Error) after this much driving [s]
};

/// @brief The robot's true state at one instant. Within one integration step the jerk is
///        constant, so acceleration is continuous and piecewise linear in time.
struct RobotState {
  double t = 0.0;      ///< [s]
  Pose2 pose;          ///< base in the world x-y plane; theta not wrapped (continuous) [m, rad]
  double v = 0.0;      ///< forward speed [m/s]
  double w = 0.0;      ///< yaw rate [rad/s]
  double a = 0.0;      ///< dv/dt [m/s^2]
  double alpha = 0.0;  ///< dw/dt [rad/s^2]
  double s = 0.0;      ///< distance driven since the start (integral of v) [m]
};

/// @brief A densely sampled true motion (uniform steps), evaluable at any time in its span.
struct RobotTrajectory {
  std::vector<RobotState> states;  ///< uniform steps of 1 / rate_hz
  double floor_z = 0.0;            ///< z of the base frame origin (the floor) [m]

  double start_time() const { return states.front().t; }
  double end_time() const { return states.back().t; }
  double length() const { return states.empty() ? 0.0 : states.back().s; }
  /// @brief State at time t (clamped to the span): the step's constant-jerk motion integrated
  ///        from the state before t, so position, heading, speeds and accelerations agree.
  /// @throws plumb::Error when the trajectory is empty.
  RobotState state_at(double t) const;
  /// @brief 3D base pose at time t: yaw about z, origin on the floor at floor_z.
  Eigen::Isometry3d T_world_base(double t) const;
};

/// @brief One integration step of the robot from `s0` over `dt` with constant jerks.
/// @return the state at s0.t + dt (position by Simpson's rule on the heading; error O(dt^5)).
RobotState integrate_robot_step(const RobotState& s0, double jerk, double angular_jerk, double dt);

/// @brief Drive along a polyline with pure pursuit, from its first point (facing its first segment).
/// @param path polyline vertices [m] (at least 2 distinct points).
/// @param closed the route returns to path[0] after the last point (a loop).
/// @param loops how many times to drive it (a closed route ends where it began).
/// @param max_length stop after this distance [m]; 0 = no limit.
/// @throws plumb::Error on bad arguments or when the robot does not arrive within max_duration.
/// @note Deterministic; O(duration * rate_hz).
RobotTrajectory drive_route(const std::vector<Vector2d>& path, bool closed, int loops, double max_length,
                            double floor_z, const RobotSettings& settings = {});

}  // namespace plumb::sim
