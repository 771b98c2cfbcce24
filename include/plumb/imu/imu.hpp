// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief IMU measurements, biases, noise model and gravity (Zhou et al. 2021, sec. 2, eq. 11-12).
///
/// Measurement model (Forster et al. 2017, eq. 26-27; Zhou et al. 2021, eq. 11-12), all in the IMU
/// (body) frame:
///   gyro  = w_body + b_g + eta_g,
///   accel = R_world_body^T (a_world - g_world) + b_a + eta_a,
/// with white noises eta of the densities below and biases b driven by random walks.

#include <cmath>

#include "plumb/core/sensor_data.hpp"
#include "plumb/core/types.hpp"

namespace plumb {

/// @brief Standard gravity [m/s^2] (CGPM 1901). Local gravity differs by up to 0.3 %; pass the
///        site's value through PreintegrationSettings::g_world when it matters.
constexpr double kStandardGravity = 9.80665;

/// @brief Gravity vector of a z-up world frame: (0, 0, -g) [m/s^2].
inline Vector3d gravity_z_up(double g = kStandardGravity) { return {0.0, 0.0, -g}; }

/// @brief Gyroscope and accelerometer biases, in the IMU frame.
struct ImuBias {
  Vector3d gyro = Vector3d::Zero();   ///< b_g [rad/s]
  Vector3d accel = Vector3d::Zero();  ///< b_a [m/s^2]
};

/// @brief Continuous-time IMU noise model (white noise densities and bias random walks).
/// Defaults: a consumer MEMS IMU (BMI088 / ICM-20948 class), the same values as the simulator's
/// "mems" preset. A sample at rate f has a white-noise std of density * sqrt(f); over dt a bias
/// drifts by random_walk * sqrt(dt).
struct ImuNoise {
  double gyro_noise_density = 1.7e-4;      ///< sigma_g [rad/s/sqrt(Hz)] (0.01 deg/s/sqrt(Hz))
  double accel_noise_density = 2.0e-3;     ///< sigma_a [m/s^2/sqrt(Hz)]
  double gyro_bias_random_walk = 2.0e-5;   ///< sigma_bg [rad/s^2/sqrt(Hz)]
  double accel_bias_random_walk = 3.0e-4;  ///< sigma_ba [m/s^3/sqrt(Hz)]

  /// @brief The consumer MEMS defaults above.
  static ImuNoise mems() { return {}; }

  /// @brief A tactical-grade IMU with 2 deg/h gyro bias instability (the test IMU of Zhou et al.
  ///        2021, sec. 4), the same values as the simulator's "2deg_h" preset: 0.15 deg/sqrt(h)
  ///        angle random walk.
  static ImuNoise tactical_2deg_h() {
    constexpr double kDeg = 3.14159265358979323846 / 180.0;
    ImuNoise n;
    n.gyro_noise_density = 0.15 * kDeg / 60.0;           // 0.15 deg/sqrt(h)
    n.gyro_bias_random_walk = 2.0 * kDeg / 3600.0 / 60.0;  // ~2 deg/h of drift within an hour
    n.accel_noise_density = 5.0e-4;
    n.accel_bias_random_walk = 3.0e-5;
    return n;
  }
};

}  // namespace plumb
