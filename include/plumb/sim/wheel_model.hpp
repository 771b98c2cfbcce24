// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Wheel encoders of a differential-drive robot: true wheel angles from the true motion
///        (with true radii and axle that differ from the nominal ones, plus slip noise), and wheel
///        odometry integrated from the angles with the nominal parameters.

#include <cstdint>
#include <vector>

#include "plumb/core/sensor_data.hpp"
#include "plumb/sim/robot.hpp"

namespace plumb::sim {

/// @brief Settings of simulate_wheels(): nominal geometry, its true deviations, noise.
struct WheelSettings {
  double radius = 0.1;               ///< nominal radius of both wheels [m]
  double axle = 0.5;                 ///< nominal wheel separation [m]
  double radius_error_left = 0.005;  ///< true left radius = radius * (1 + this) (dimensionless)
  double radius_error_right = -0.005;  ///< true right radius = radius * (1 + this)
  double axle_error = 0.01;          ///< true axle = axle * (1 + this)
  double slip_sigma = 0.01;          ///< relative slip of each wheel increment, std dev (dimensionless)
  double rate_hz = 50.0;             ///< encoder reading rate [Hz]
  std::uint64_t seed = 1;            ///< slip noise depends on this only
};

/// @brief Encoder readings (cumulative angles, forward positive, 0 at the start) at rate_hz over
///        the trajectory's span. Wheel k rolls the distance its contact point travels,
///        s -/+ (true axle / 2) * theta, divided by its true radius; each increment is scaled by
///        (1 + slip_sigma * N(0, 1)).
/// @throws plumb::Error on non-positive radius, axle or rate, or an empty trajectory.
std::vector<WheelEncoderReading> simulate_wheels(const RobotTrajectory& trajectory, const WheelSettings& settings = {});

/// @brief Dead reckoning from encoder readings: per interval, left/right arc lengths r * dphi,
///        then the constant-curvature motion (ds, dtheta) composed with ⊕ (Liu et al. 2022, eq. 13).
/// @param start pose of the first reading (identity = the odometry frame starts at the base).
/// @throws plumb::Error on non-positive parameters or non-increasing stamps.
std::vector<OdomSample> integrate_wheel_odometry(const std::vector<WheelEncoderReading>& wheels,
                                                     double radius_left, double radius_right, double axle,
                                                     const Pose2& start = Pose2{});

}  // namespace plumb::sim
