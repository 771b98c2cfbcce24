// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/sim/imu_model.hpp"

#include <cmath>

#include "plumb/core/error.hpp"
#include "plumb/core/rng.hpp"

namespace plumb::sim {

ImuSettings imu_preset(const std::string& name) {
  ImuSettings s;
  if (name == "mems") return s;
  if (name == "2deg_h") {
    constexpr double kDegPerHour = 3.14159265358979323846 / 180.0 / 3600.0;
    s.gyro_noise_density = 0.15 * 3.14159265358979323846 / 180.0 / 60.0;  // 0.15 deg/sqrt(h) ARW
    s.gyro_bias_sigma = 2.0 * kDegPerHour;
    s.gyro_bias_random_walk = 2.0 * kDegPerHour / 60.0;  // drifts by ~2 deg/h within an hour
    s.accel_noise_density = 5.0e-4;
    s.accel_bias_random_walk = 3.0e-5;
    s.accel_bias_sigma = 5.0e-3;
    return s;
  }
  if (name == "ideal") {
    s.gyro_noise_density = s.accel_noise_density = 0.0;
    s.gyro_bias_random_walk = s.accel_bias_random_walk = 0.0;
    s.gyro_bias_sigma = s.accel_bias_sigma = 0.0;
    return s;
  }
  PLUMB_THROW("imu_preset: unknown IMU '" << name << "' (known: mems, 2deg_h, ideal)");
}

ImuSimulation simulate_imu(const RobotTrajectory& trajectory, const Eigen::Isometry3d& T_base_imu,
                           const ImuSettings& s) {
  PLUMB_CHECK(!trajectory.states.empty(), "simulate_imu: empty trajectory");
  PLUMB_CHECK(s.rate_hz > 0.0 && std::isfinite(s.rate_hz), "simulate_imu: rate_hz must be positive, got " << s.rate_hz);
  PLUMB_CHECK(s.gyro_noise_density >= 0.0 && s.accel_noise_density >= 0.0 && s.gyro_bias_random_walk >= 0.0 &&
                  s.accel_bias_random_walk >= 0.0 && s.gyro_bias_sigma >= 0.0 && s.accel_bias_sigma >= 0.0,
              "simulate_imu: noise parameters must not be negative");
  Rng rng(s.seed);
  auto normal3 = [&rng] {
    const double x = rng.normal(), y = rng.normal(), z = rng.normal();
    return Vector3d(x, y, z);
  };
  const double dt = 1.0 / s.rate_hz;
  const double sigma_w = s.gyro_noise_density * std::sqrt(s.rate_hz);
  const double sigma_f = s.accel_noise_density * std::sqrt(s.rate_hz);
  const double walk_w = s.gyro_bias_random_walk * std::sqrt(dt);
  const double walk_f = s.accel_bias_random_walk * std::sqrt(dt);
  Vector3d bias_w = s.gyro_bias_sigma * normal3();
  Vector3d bias_f = s.accel_bias_sigma * normal3();
  const Eigen::Matrix3d R_imu_base = T_base_imu.linear().transpose();
  const Vector3d r = T_base_imu.translation();
  ImuSimulation out;
  const double t0 = trajectory.start_time(), t1 = trajectory.end_time();
  for (std::size_t k = 0;; ++k) {
    const double t = t0 + static_cast<double>(k) * dt;
    if (t > t1 + 1e-9) break;
    if (k > 0) {
      bias_w += walk_w * normal3();
      bias_f += walk_f * normal3();
    }
    const RobotState st = trajectory.state_at(t);
    const Vector3d w_base(0.0, 0.0, st.w), alpha_base(0.0, 0.0, st.alpha);
    // Acceleration of the IMU point in base coordinates, minus gravity (world z up, base z = world z).
    const Vector3d acc_base = Vector3d(st.a, st.v * st.w, 0.0) + alpha_base.cross(r) + w_base.cross(w_base.cross(r));
    const Vector3d f_base = acc_base + Vector3d(0.0, 0.0, s.gravity);
    ImuSample m;
    m.stamp = t;
    m.gyro = R_imu_base * w_base + bias_w + sigma_w * normal3();
    m.accel = R_imu_base * f_base + bias_f + sigma_f * normal3();
    out.samples.push_back(m);
    out.gyro_bias.push_back(bias_w);
    out.accel_bias.push_back(bias_f);
  }
  return out;
}

}  // namespace plumb::sim
