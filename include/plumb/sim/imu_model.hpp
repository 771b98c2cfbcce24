// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief IMU model: true angular rate and specific force of the IMU mounted on the robot, with
///        white noise and bias random walk (the usual continuous-time model, e.g. Kalibr's
///        IMU noise model: discrete sigma = density * sqrt(rate), bias step = walk * sqrt(dt)).

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "plumb/core/sensor_data.hpp"
#include "plumb/sim/robot.hpp"

namespace plumb::sim {

/// @brief Settings of simulate_imu(). Defaults: a consumer MEMS IMU (BMI088 / ICM-20948 class).
struct ImuSettings {
  double rate_hz = 200.0;                 ///< sample rate [Hz]
  double gyro_noise_density = 1.7e-4;     ///< [rad/s/sqrt(Hz)] (0.01 deg/s/sqrt(Hz))
  double accel_noise_density = 2.0e-3;    ///< [m/s^2/sqrt(Hz)]
  double gyro_bias_random_walk = 2.0e-5;  ///< [rad/s^2/sqrt(Hz)]
  double accel_bias_random_walk = 3.0e-4; ///< [m/s^3/sqrt(Hz)]
  double gyro_bias_sigma = 2.0e-3;        ///< initial bias, per axis std dev [rad/s]
  double accel_bias_sigma = 0.03;         ///< initial bias, per axis std dev [m/s^2]
  double gravity = 9.81;                  ///< |g| [m/s^2]; world z is up
  std::uint64_t seed = 1;                 ///< noise and biases depend on this only
};

/// @brief Preset noise models: "mems" (the defaults) or "2deg_h" (tactical grade: 2 deg/h gyro
///        bias instability, as seed B's option), "ideal" (no noise, no bias).
/// @throws plumb::Error for an unknown name.
ImuSettings imu_preset(const std::string& name);

/// @brief Simulated measurements and the true biases that were added.
struct ImuSimulation {
  std::vector<ImuSample> samples;  ///< stamps every 1 / rate_hz from the trajectory's start
  std::vector<Vector3d> gyro_bias;     ///< true gyro bias at each sample [rad/s]
  std::vector<Vector3d> accel_bias;    ///< true accelerometer bias at each sample [m/s^2]
};

/// @brief The IMU at `T_base_imu` on the robot: w_imu = R_base_imu^T w_base, f_imu =
///        R_base_imu^T R_world_base^T (a_world(imu point) - g_world), plus bias and white noise.
/// The IMU point's acceleration is exact for the planar rigid motion: base acceleration
/// (a, v w, 0) plus alpha x r + w x (w x r), r the lever arm.
/// @throws plumb::Error on a non-positive rate, negative noise or an empty trajectory.
ImuSimulation simulate_imu(const RobotTrajectory& trajectory, const Eigen::Isometry3d& T_base_imu,
                           const ImuSettings& settings = {});

}  // namespace plumb::sim
