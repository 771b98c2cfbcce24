// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief The sensor readings every module shares, defined once: an IMU reading, a wheel-odometry
///        pose, a wheel-encoder reading, a calibration tuple (wheel speeds and laser motion over an
///        interval), and SE(2) interpolation between odometry poses. (A planar
///        laser scan is plumb/core/laser_scan.hpp; a point cloud plumb/core/point_cloud.hpp.)

#include <cmath>

#include "plumb/core/error.hpp"
#include "plumb/core/pose2.hpp"
#include "plumb/core/types.hpp"

namespace plumb {

/// @brief One IMU reading in the IMU frame.
struct ImuSample {
  double stamp = 0.0;                 ///< [s]
  Vector3d gyro = Vector3d::Zero();   ///< measured angular rate w_body + b_g [rad/s]
  Vector3d accel = Vector3d::Zero();  ///< measured specific force R^T (a_world - g_world) + b_a [m/s^2]
};

/// @brief One wheel-odometry pose (the base in the odometry frame).
struct OdomSample {
  double stamp = 0.0;  ///< [s]
  Pose2 pose;          ///< x y [m], theta [rad]
};

/// @brief One wheel encoder reading: cumulative wheel angles at a time.
struct WheelEncoderReading {
  double stamp = 0.0;  ///< [s]
  double left = 0.0;   ///< cumulative left wheel angle [rad] (forward positive)
  double right = 0.0;  ///< cumulative right wheel angle [rad] (forward positive)

  /// @brief A reading from tick counters: angle = 2π ticks / ticks_per_revolution.
  /// @throws plumb::Error when ticks_per_revolution <= 0.
  static WheelEncoderReading from_ticks(double stamp, double left_ticks, double right_ticks,
                                        double ticks_per_revolution) {
    PLUMB_CHECK(ticks_per_revolution > 0.0 && std::isfinite(ticks_per_revolution),
                "WheelEncoderReading::from_ticks: ticks_per_revolution must be > 0, got " << ticks_per_revolution);
    constexpr double kTwoPi = 6.283185307179586476925;
    return {stamp, kTwoPi * left_ticks / ticks_per_revolution, kTwoPi * right_ticks / ticks_per_revolution};
  }
};

/// @brief One calibration sample: an interval with its mean wheel speeds and the laser's motion
///        over the interval as estimated by a scan matcher (the fields of Censi's `.tuple` files).
struct CalibrationTuple {
  double T = 0.0;          ///< interval length [s], > 0
  double phi_left = 0.0;   ///< mean left wheel angular velocity over the interval [rad/s]
  double phi_right = 0.0;  ///< mean right wheel angular velocity over the interval [rad/s]
  Pose2 laser_motion;      ///< ŝ: laser pose at the end in the laser frame at the start [m, rad]
};

/// @brief Interpolate between poses a (alpha = 0) and b (alpha = 1) along the relative motion
///        r = ⊖a ⊕ b: a ⊕ (alpha r_x, alpha r_y, alpha wrap(r_theta)); angle-aware across ±pi.
inline Pose2 interpolate_pose2(const Pose2& a, const Pose2& b, double alpha) {
  const Pose2 r = a.ominus().oplus(b);
  return a.oplus(Pose2{alpha * r.x, alpha * r.y, alpha * wrap_angle(r.theta)});
}

}  // namespace plumb
