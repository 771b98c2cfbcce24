// SPDX-License-Identifier: BSD-3-Clause
// Deskewing a frame with the wheel odometry: OdometryInterpolator and deskew_frame.
#include "plumb/core/deskew.hpp"

#include <vector>

#include <gtest/gtest.h>

#include "plumb/core/error.hpp"

namespace {

TEST(DeskewTest, UndoesAConstantMotion) {
  // The sensor moves 1 m/s along x: a point seen at time t at sensor-frame x was at x + t in the
  // frame of the stamp.
  plumb::PointCloud f;
  f.points = {{1, 0, 0}, {2, 1, 0}, {0, 3, 1}};
  f.times = {0.0f, 0.05f, 0.1f};
  Eigen::Isometry3d T_base_lidar = Eigen::Isometry3d::Identity();
  T_base_lidar.translation() << 0.3, 0, 0.5;
  plumb::deskew_frame(f, 10.0, T_base_lidar, [](double t) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation().x() = t - 10.0;
    return T;
  });
  EXPECT_NEAR(f.points[0].x(), 1.0f, 1e-6f);
  EXPECT_NEAR(f.points[1].x(), 2.05f, 1e-6f);
  EXPECT_NEAR(f.points[2].x(), 0.1f, 1e-6f);
  EXPECT_NEAR(f.points[2].y(), 3.0f, 1e-6f);
  plumb::PointCloud bad = f;
  bad.times.pop_back();
  EXPECT_THROW(plumb::deskew_frame(bad, 0, T_base_lidar, [](double) { return Eigen::Isometry3d::Identity(); }),
               plumb::Error);
}

TEST(OdometryInterpolatorTest, InterpolatesClampsAndRejectsBadSamples) {
  std::vector<plumb::OdomSample> samples(2);
  samples[0].stamp = 1.0;
  samples[1].stamp = 2.0;
  samples[1].pose = plumb::Pose2{2.0, 0.0, 0.0};
  const plumb::OdometryInterpolator odom(samples);
  EXPECT_NEAR(odom.at(1.25).x, 0.5, 1e-12);
  EXPECT_NEAR(odom.at(0.0).x, 0.0, 1e-12);   // before the first sample: the first
  EXPECT_NEAR(odom.at(9.0).x, 2.0, 1e-12);   // after the last: the last
  EXPECT_THROW(plumb::OdometryInterpolator({}), plumb::Error);
  samples[1].stamp = 1.0;  // not increasing
  EXPECT_THROW(plumb::OdometryInterpolator{samples}, plumb::Error);
}

}  // namespace
