// SPDX-License-Identifier: BSD-3-Clause
// BimOdometry: the front end's step covariance against the wheels, and input it refuses.
#include "plumb/pipeline/bim_odometry.hpp"

#include <cmath>
#include <memory>
#include <vector>

#include <gtest/gtest.h>

#include "plumb/core/error.hpp"

namespace {

TEST(FrontEndStepCovarianceTest, MatchesWithinTheWheelBudgetKeepTheirCovariance) {
  const plumb::BimOdometrySettings s;
  const plumb::Pose2 front{0.08, 0.01, 0.02};
  plumb::Matrix3d plicp = plumb::Matrix3d::Zero();
  plicp(0, 0) = 4e-6;
  plicp(0, 2) = plicp(2, 0) = 1e-7;
  // The motion noise alone, written out: sigma per metre times the distance (+ turn for theta).
  const double dist = std::hypot(0.08, 0.01);
  const double sxy = s.motion_sigma_xy * dist + 1e-4, sth = s.motion_sigma_theta * (0.02 + dist) + 1e-5;
  plumb::Matrix3d expected = plumb::Vector3d(sxy * sxy, sxy * sxy, sth * sth).asDiagonal();
  expected += plicp;
  // The wheels 9 mm and 0.009 rad away: inside the budget (1 cm + 10 % of the step), nothing added.
  const plumb::Pose2 wheel{0.08 - 0.009, 0.01, 0.02 + 0.009};
  EXPECT_TRUE(plumb::front_end_step_covariance(s, front, wheel, true, plicp).isApprox(expected, 1e-12));
  EXPECT_TRUE(plumb::front_end_step_covariance(s, front, front, true, plicp).isApprox(expected, 1e-12));
  // Not a match (fallback to the wheels): the fallback noise, no PLICP covariance, no wheel test.
  const double fxy = s.fallback_sigma_xy * dist + 1e-4, fth = s.fallback_sigma_theta * (0.02 + dist) + 1e-5;
  const plumb::Matrix3d fallback = plumb::Vector3d(fxy * fxy, fxy * fxy, fth * fth).asDiagonal();
  EXPECT_TRUE(plumb::front_end_step_covariance(s, front, wheel, false, plicp).isApprox(fallback, 1e-12));
  // A step across +-pi (the front end wraps its poses; Pose2's operators do not): the same as the
  // small turn it is, not a turn of 2 pi.
  const plumb::Pose2 across{0.08, 0.01, 0.02 - 2.0 * M_PI};
  EXPECT_TRUE(plumb::front_end_step_covariance(s, across, front, true, plicp).isApprox(expected, 1e-9));
}

TEST(FrontEndStepCovarianceTest, AGlitchIsAsUncertainAsItsExcessOverTheWheels) {
  const plumb::BimOdometrySettings s;
  const plumb::Pose2 wheel{0.047, 0.0, 0.0};
  const plumb::Pose2 glitch{0.089, -0.005, 0.05};  // PLICP jumped 4 cm and 0.05 rad where the wheels did not
  const plumb::Matrix3d zero = plumb::Matrix3d::Zero();
  const plumb::Matrix3d base = plumb::front_end_step_covariance(s, glitch, glitch, true, zero);
  const plumb::Matrix3d c = plumb::front_end_step_covariance(s, glitch, wheel, true, zero);
  const double dist = std::hypot(0.089, 0.005);
  const double exy = std::hypot(0.089 - 0.047, 0.005) - 0.01 - 0.1 * dist;
  const double eth = 0.05 - 0.01 - 0.1 * 0.05;
  EXPECT_NEAR(c(0, 0) - base(0, 0), exy * exy, 1e-12);
  EXPECT_NEAR(c(1, 1) - base(1, 1), exy * exy, 1e-12);
  EXPECT_NEAR(c(2, 2) - base(2, 2), eth * eth, 1e-12);
  EXPECT_NEAR(c(0, 1), 0.0, 1e-15);
  // Bad tolerances are misuse.
  plumb::BimOdometrySettings bad;
  bad.use_bim = false;
  bad.wheel_tolerance_ratio = -0.1;
  EXPECT_THROW(plumb::BimOdometry(nullptr, Eigen::Isometry3d::Identity(), bad), plumb::Error);
}

TEST(FrontEndStepCovarianceTest, TheNextAnchorRemovesAGlitchInsteadOfBeingRejected) {
  // A robot driving 5 cm per frame along x, anchored every frame by key points registered to the BIM
  // (4 mm, the size of BimOdometry's anchors). At frame 10 the scan match jumps 4.6 cm ahead, the wheels
  // do not (a PLICP glitch measured on an AC20-FZK-Haus run). With the wheel test the first anchor after
  // the glitch passes the gate and removes it; without it (tolerance off) the composer, confident in its
  // chain, rejects the anchors and carries the error on.
  auto run = [](double wheel_tolerance) {
    plumb::BimOdometrySettings s;
    s.wheel_tolerance_xy = wheel_tolerance;
    plumb::PoseComposer composer(Eigen::Isometry3d::Identity(), s.initial_covariance, s.composer);
    plumb::Matrix6d info = plumb::Matrix6d::Zero();
    info(0, 0) = info(1, 1) = 1.0 / (0.004 * 0.004);
    info(5, 5) = 1.0 / (0.001 * 0.001);
    std::vector<double> errors;
    const plumb::Pose2 wheel{0.05, 0.0, 0.0};
    for (int k = 1; k <= 20; ++k) {
      const plumb::Pose2 front = k == 10 ? plumb::Pose2{0.096, 0.0, 0.0} : wheel;
      const plumb::Matrix3d c = plumb::front_end_step_covariance(s, front, wheel, true, plumb::Matrix3d::Zero());
      composer.add_motion(front.to_isometry(), plumb::planar_covariance(c, 1e-8, 1e-8));
      Eigen::Isometry3d truth = Eigen::Isometry3d::Identity();
      truth.translation().x() = 0.05 * k;
      composer.add_anchor(truth, info);
      errors.push_back(std::abs(composer.pose().translation().x() - truth.translation().x()));
    }
    return errors;
  };
  const std::vector<double> with = run(0.01), without = run(1e9);
  for (int k = 1; k <= 9; ++k) EXPECT_NEAR(with[k - 1], without[k - 1], 1e-12) << "frame " << k;
  EXPECT_LT(with[9], 0.005);     // frame 10: corrected by its own anchor
  EXPECT_GT(without[9], 0.04);   // rejected: the whole jump stays
  EXPECT_GT(without[11], 0.04);  // and two frames later it still does
}

TEST(BimOdometryTest, BadInputThrows) {
  auto empty = std::make_shared<plumb::PointCloud>();
  EXPECT_THROW(plumb::BimOdometry(empty, Eigen::Isometry3d::Identity()), plumb::Error);
  auto no_normals = std::make_shared<plumb::PointCloud>();
  for (int i = 0; i < 200; ++i) no_normals->points.emplace_back(float(i % 20), float(i / 20), 0.0f);
  EXPECT_THROW(plumb::BimOdometry(no_normals, Eigen::Isometry3d::Identity()), plumb::Error);
  plumb::BimOdometrySettings plain;
  plain.use_bim = false;
  plumb::BimOdometry odometry(nullptr, Eigen::Isometry3d::Identity(), plain);
  // An empty frame: no scan, the front end falls back to the wheel prior; never a crash.
  const auto r0 = odometry.process(plumb::PointCloud{}, 0.0, plumb::Pose2{});
  const auto r1 = odometry.process(plumb::PointCloud{}, 0.1, plumb::Pose2{0.1, 0, 0});
  EXPECT_EQ(r1.scan_status, plumb::Status::kInsufficientData);
  EXPECT_NEAR(r1.T_world_base.translation().x(), 0.1, 1e-9);
  EXPECT_FALSE(r0.anchor_attempted);
}

}  // namespace
