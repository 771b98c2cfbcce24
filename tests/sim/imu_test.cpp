// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/sim/imu_model.hpp"

#include <cmath>

#include <gtest/gtest.h>

#include "plumb/core/error.hpp"
#include "plumb/core/lie.hpp"

namespace plumb::sim {
namespace {

RobotTrajectory loop_trajectory() {
  return drive_route({{0, 0}, {6, 0}, {6, 3}, {4, 3}, {3, 1.5}, {2, 3}, {0, 3}}, true, 1, 0.0, 0.3);
}

/// An IMU mounted off-centre and rotated, so lever arm and frame changes are exercised.
Eigen::Isometry3d mount() {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = (Eigen::AngleAxisd(2.0, Vector3d::UnitZ()) * Eigen::AngleAxisd(0.3, Vector3d::UnitX()) *
                Eigen::AngleAxisd(-0.2, Vector3d::UnitY()))
                   .toRotationMatrix();
  T.translation() = Vector3d(0.3, -0.15, 0.4);
  return T;
}

/// World velocity of the IMU point from the ground-truth poses by central differences.
Vector3d imu_velocity(const RobotTrajectory& traj, const Eigen::Isometry3d& T_base_imu, double t) {
  const double h = 1e-4;
  const Vector3d a = traj.T_world_base(t - h) * T_base_imu.translation();
  const Vector3d b = traj.T_world_base(t + h) * T_base_imu.translation();
  return (b - a) / (2 * h);
}

TEST(ImuTest, ZeroNoiseIntegratesToGroundTruth) {
  const RobotTrajectory traj = loop_trajectory();
  const Eigen::Isometry3d T_base_imu = mount();
  ImuSettings s = imu_preset("ideal");
  s.rate_hz = 200.0;
  const ImuSimulation sim = simulate_imu(traj, T_base_imu, s);
  const auto& m = sim.samples;
  ASSERT_GT(m.size(), 1000u);
  const Vector3d g_world(0, 0, -s.gravity);
  // Windows of 1 s (200 samples) along the whole run: integrate rotation and velocity from the
  // true state at the window start and compare with the truth at its end.
  for (std::size_t i = 0; i + 200 < m.size(); i += 150) {
    const std::size_t j = i + 200;
    Eigen::Matrix3d R = (traj.T_world_base(m[i].stamp) * T_base_imu).linear();
    Vector3d v = imu_velocity(traj, T_base_imu, m[i].stamp);
    for (std::size_t k = i; k < j; ++k) {
      const double dt = m[k + 1].stamp - m[k].stamp;
      const Eigen::Matrix3d R_next = R * so3::exp(0.5 * (m[k].gyro + m[k + 1].gyro) * dt);
      v += 0.5 * (R * m[k].accel + R_next * m[k + 1].accel) * dt + g_world * dt;  // trapezoid
      R = R_next;
    }
    const Eigen::Matrix3d R_true = (traj.T_world_base(m[j].stamp) * T_base_imu).linear();
    ASSERT_LT(so3::log(R_true.transpose() * R).norm(), 1e-5) << "window at " << m[i].stamp;
    ASSERT_LT((v - imu_velocity(traj, T_base_imu, m[j].stamp)).norm(), 2e-4) << "window at " << m[i].stamp;
  }
  // At rest (the first second) the IMU measures only gravity, in its own frame.
  const Vector3d f_rest = T_base_imu.linear().transpose() * Vector3d(0, 0, s.gravity);
  EXPECT_LT((m[10].accel - f_rest).norm(), 1e-12);
  EXPECT_LT(m[10].gyro.norm(), 1e-12);
}

TEST(ImuTest, NoiseAndBiasFollowTheSettings) {
  const RobotTrajectory still = drive_route({{0, 0}, {0.2, 0}}, false, 1, 0.0, 0.0);  // mostly at rest
  ImuSettings s;  // MEMS defaults
  s.rate_hz = 300.0;
  s.gyro_bias_random_walk = s.accel_bias_random_walk = 0.0;  // constant biases for this check
  const ImuSimulation sim = simulate_imu(still, Eigen::Isometry3d::Identity(), s);
  // First second: at rest. Sample std of (measurement - truth - bias) = density * sqrt(rate).
  double sum_w = 0.0, sum_f = 0.0;
  std::size_t n = 0;
  for (std::size_t k = 0; k < sim.samples.size() && sim.samples[k].stamp < 0.95; ++k, ++n) {
    sum_w += (sim.samples[k].gyro - sim.gyro_bias[k]).squaredNorm();
    sum_f += (sim.samples[k].accel - Vector3d(0, 0, s.gravity) - sim.accel_bias[k]).squaredNorm();
  }
  ASSERT_GT(n, 250u);
  const double sigma_w = std::sqrt(sum_w / (3.0 * n)), sigma_f = std::sqrt(sum_f / (3.0 * n));
  EXPECT_NEAR(sigma_w, s.gyro_noise_density * std::sqrt(s.rate_hz), 0.1 * s.gyro_noise_density * std::sqrt(s.rate_hz));
  EXPECT_NEAR(sigma_f, s.accel_noise_density * std::sqrt(s.rate_hz), 0.1 * s.accel_noise_density * std::sqrt(s.rate_hz));
  EXPECT_GT(sim.gyro_bias.front().norm(), 0.0);
  EXPECT_EQ(sim.gyro_bias.front(), sim.gyro_bias.back());
  // Stamps at the rate, deterministic for a seed.
  EXPECT_NEAR(sim.samples[3].stamp - sim.samples[2].stamp, 1.0 / 300.0, 1e-12);
  const ImuSimulation again = simulate_imu(still, Eigen::Isometry3d::Identity(), s);
  EXPECT_EQ(again.samples.back().accel, sim.samples.back().accel);
  s.seed = 9;
  EXPECT_NE(simulate_imu(still, Eigen::Isometry3d::Identity(), s).samples.back().accel, sim.samples.back().accel);
}

TEST(ImuTest, TacticalPresetIsTwoDegreesPerHour) {
  const ImuSettings t = imu_preset("2deg_h");
  EXPECT_NEAR(t.gyro_bias_sigma * 180.0 / 3.14159265358979 * 3600.0, 2.0, 1e-9);
  EXPECT_LT(t.gyro_noise_density, imu_preset("mems").gyro_noise_density);
  EXPECT_THROW(imu_preset("navigation"), Error);
  ImuSettings bad;
  bad.rate_hz = 0.0;
  EXPECT_THROW(simulate_imu(loop_trajectory(), Eigen::Isometry3d::Identity(), bad), Error);
  EXPECT_THROW(simulate_imu(RobotTrajectory{}, Eigen::Isometry3d::Identity()), Error);
}

}  // namespace
}  // namespace plumb::sim
