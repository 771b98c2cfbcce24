// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/scan2d/cloud_to_scan.hpp"

#include <cmath>
#include <iostream>
#include <limits>
#include <vector>

#include <gtest/gtest.h>

#include "plumb/core/rng.hpp"
#include "plumb/io/cloud_io.hpp"
#include "plumb/scan2d/plicp.hpp"
#include "plumb/segmentation/segment_frame.hpp"
#include "test_data.hpp"

namespace plumb {
namespace {


PointCloud cloud_of(std::initializer_list<Vector3f> pts) {
  PointCloud c;
  c.points.assign(pts.begin(), pts.end());
  return c;
}

TEST(CloudToScanTest, NearestPointPerBinAndInfForEmptyBins) {
  CloudToScanSettings s;
  s.angle_min = -kPi / 2;
  s.angle_max = kPi / 2;
  s.angle_increment = kPi / 4;  // 4 bins: [-90,-45) [-45,0) [0,45) [45,90]
  s.min_height = -0.5;
  s.max_height = 0.5;
  // Bin 2 (0..45 deg) has two points: ranges 3 and 2 -> 2. Bin 0 has one at range 1.
  const PointCloud c = cloud_of({{3.0f * std::cos(0.3f), 3.0f * std::sin(0.3f), 0.0f},
                                 {2.0f * std::cos(0.5f), 2.0f * std::sin(0.5f), 0.2f},
                                 {0.0f, -1.0f, 0.0f},                        // -90 deg, bin 0
                                 {5.0f, 0.1f, 0.8f},                         // above the band
                                 {-4.0f, 0.0f, 0.0f},                        // behind: outside angles
                                 {std::nanf(""), 0.0f, 0.0f}});
  const CloudToScanResult r = cloud_to_scan(c, s);
  ASSERT_EQ(r.scan.size(), 4u);
  EXPECT_EQ(r.status, Status::kOk);
  EXPECT_FLOAT_EQ(r.scan.ranges[0], 1.0f);
  EXPECT_TRUE(std::isinf(r.scan.ranges[1]));
  EXPECT_NEAR(r.scan.ranges[2], 2.0f, 1e-6);
  EXPECT_TRUE(std::isinf(r.scan.ranges[3]));
  EXPECT_EQ(r.num_in_band, 4u);  // the 3 in front + the one behind
  ASSERT_EQ(r.points.size(), 2u);
  EXPECT_EQ(r.beam_indices[0], 0u);
  EXPECT_EQ(r.source_indices[1], 1u);
  EXPECT_NEAR(r.points[1].x(), 2.0 * std::cos(0.5), 1e-6);
  EXPECT_NEAR(r.points[1].y(), 2.0 * std::sin(0.5), 1e-6);
  EXPECT_EQ(r.scan.num_valid(), 2u);  // inf beams are invalid for PLICP
}

TEST(CloudToScanTest, MatchesPerBinBruteForceOnRandomCloud) {
  Rng rng(7);
  PointCloud c;
  for (int i = 0; i < 5000; ++i) {
    c.points.emplace_back(static_cast<float>(rng.uniform(-10, 10)), static_cast<float>(rng.uniform(-10, 10)),
                          static_cast<float>(rng.uniform(-1, 1)));
  }
  CloudToScanSettings s;
  s.min_height = -0.2;
  s.max_height = 0.3;
  s.range_min = 0.5;
  s.range_max = 8.0;
  s.angle_increment = kPi / 90;
  const CloudToScanResult r = cloud_to_scan(c, s);
  ASSERT_EQ(r.scan.size(), 180u);
  // Oracle: for each bin, scan every point again.
  for (std::size_t b = 0; b < r.scan.size(); ++b) {
    double best = std::numeric_limits<double>::infinity();
    for (const Vector3f& p : c.points) {
      if (p.z() < s.min_height || p.z() > s.max_height) continue;
      const double range = std::hypot(static_cast<double>(p.x()), static_cast<double>(p.y()));
      if (range < s.range_min || range > s.range_max) continue;
      const double a = std::atan2(static_cast<double>(p.y()), static_cast<double>(p.x()));
      const double lo = s.angle_min + static_cast<double>(b) * s.angle_increment;
      if (a >= lo && a < lo + s.angle_increment) best = std::min(best, range);
    }
    if (std::isinf(best)) {
      EXPECT_TRUE(std::isinf(r.scan.ranges[b])) << "bin " << b;
    } else {
      EXPECT_NEAR(r.scan.ranges[b], best, 1e-5) << "bin " << b;
    }
  }
}

// A tilted, shifted sensor: every point that reaches the scan is the one a plain loop over R * p + t
// picks per bin, with the same coordinates to the bit (the height is tested before x and y are
// made, and must come out as the full transform would give it).
TEST(CloudToScanTest, TiltedSensorMatchesAPlainLoopOverTheTransformedPoints) {
  Rng rng(23);
  PointCloud c;
  for (int i = 0; i < 20000; ++i) {
    c.points.emplace_back(static_cast<float>(rng.uniform(-12, 12)), static_cast<float>(rng.uniform(-12, 12)),
                          static_cast<float>(rng.uniform(-3, 3)));
  }
  CloudToScanSettings s;
  s.min_height = 0.6;
  s.max_height = 1.4;
  s.range_min = 0.3;
  s.angle_increment = kPi / 360;
  s.T_target_sensor = Eigen::Translation3d(0.31, -0.12, 1.02) *
                      Eigen::AngleAxisd(0.03, Eigen::Vector3d::UnitX()) *
                      Eigen::AngleAxisd(-0.02, Eigen::Vector3d::UnitY()) * Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitZ());
  const CloudToScanResult r = cloud_to_scan(c, s);
  std::vector<double> best(r.scan.size(), std::numeric_limits<double>::infinity());
  std::vector<std::size_t> source(r.scan.size(), 0);
  std::vector<Eigen::Vector3d> moved(c.size());
  std::size_t in_band = 0;
  for (std::size_t i = 0; i < c.size(); ++i) {
    const Eigen::Vector3d p = s.T_target_sensor.linear() * c.points[i].cast<double>() + s.T_target_sensor.translation();
    moved[i] = p;
    if (p.z() < s.min_height || p.z() > s.max_height) continue;
    ++in_band;
    const double r_sq = p.x() * p.x() + p.y() * p.y();
    if (r_sq < s.range_min * s.range_min) continue;
    const double a = std::atan2(p.y(), p.x());
    std::size_t b = static_cast<std::size_t>((a - s.angle_min) / s.angle_increment);
    if (b >= best.size()) b = best.size() - 1;
    if (r_sq < best[b]) {
      best[b] = r_sq;
      source[b] = i;
    }
  }
  EXPECT_EQ(r.num_in_band, in_band);
  std::size_t k = 0;
  for (std::size_t b = 0; b < best.size(); ++b) {
    if (std::isinf(best[b])) continue;
    ASSERT_LT(k, r.points.size());
    EXPECT_EQ(r.beam_indices[k], b);
    EXPECT_EQ(r.source_indices[k], source[b]) << "bin " << b;
    EXPECT_EQ(r.points[k].x(), moved[source[b]].x()) << "bin " << b;
    EXPECT_EQ(r.points[k].y(), moved[source[b]].y()) << "bin " << b;
    EXPECT_EQ(r.scan.ranges[b], static_cast<float>(std::sqrt(best[b]))) << "bin " << b;
    ++k;
  }
  EXPECT_EQ(k, r.points.size());
  EXPECT_GT(k, 600u);  // the band holds enough points to fill most bins
}

TEST(CloudToScanTest, SensorToBaseTransformMovesTheBand) {
  // A wall at x = 2 from z = -1 to 1 in the sensor frame; the sensor is 1 m above the base.
  PointCloud c;
  for (int k = 0; k <= 20; ++k) c.points.emplace_back(2.0f, 0.0f, -1.0f + 0.1f * static_cast<float>(k));
  c.points.emplace_back(1.0f, 0.0f, -0.95f);  // a low obstacle, 1.05 m below the sensor
  CloudToScanSettings s;
  s.min_height = -0.1;
  s.max_height = 0.1;
  EXPECT_NEAR(cloud_to_scan(c, s).scan.ranges[360], 2.0f, 1e-6);
  s.T_target_sensor.translation() = Eigen::Vector3d(0.5, 0.0, 1.0);  // base frame: obstacle at z 0.05
  const CloudToScanResult r = cloud_to_scan(c, s);
  EXPECT_NEAR(r.scan.ranges[360], 1.5f, 1e-6);
  s.T_target_sensor.linear() = Eigen::AngleAxisd(kPi / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const CloudToScanResult rotated = cloud_to_scan(c, s);
  // Rotated 90 deg: the obstacle is now at (0.5, 1) -> range hypot(0.5, 1), angle atan2(1, 0.5).
  const std::size_t bin = static_cast<std::size_t>((std::atan2(1.0, 0.5) + kPi) / s.angle_increment);
  EXPECT_NEAR(rotated.scan.ranges[bin], std::hypot(0.5, 1.0), 1e-5);
}

TEST(CloudToScanTest, EmptyAndAllNanGiveInfScanAndStatus) {
  PointCloud empty;
  const CloudToScanResult r = cloud_to_scan(empty);
  EXPECT_EQ(r.status, Status::kInsufficientData);
  EXPECT_EQ(r.scan.size(), 720u);
  EXPECT_EQ(r.scan.num_valid(), 0u);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const CloudToScanResult n = cloud_to_scan(cloud_of({{nan, nan, nan}, {1.0f, nan, 0.0f}}));
  EXPECT_EQ(n.status, Status::kInsufficientData);
  EXPECT_TRUE(n.points.empty());
}

TEST(CloudToScanTest, InvalidSettingsThrow) {
  const PointCloud c = cloud_of({{1, 0, 0}});
  CloudToScanSettings s;
  s.angle_increment = 0.0;
  EXPECT_THROW(cloud_to_scan(c, s), Error);
  s = {};
  s.angle_max = s.angle_min;
  EXPECT_THROW(cloud_to_scan(c, s), Error);
  s = {};
  s.min_height = 1.0;
  s.max_height = 0.0;
  EXPECT_THROW(cloud_to_scan(c, s), Error);
  s = {};
  s.range_min = std::nan("");
  EXPECT_THROW(cloud_to_scan(c, s), Error);
}

TEST(CloudToScanTest, AngleMaxPointGoesToLastBin) {
  CloudToScanSettings s;
  s.angle_min = 0.0;
  s.angle_max = kPi / 2;
  s.angle_increment = kPi / 8;
  const CloudToScanResult r = cloud_to_scan(cloud_of({{0.0f, 3.0f, 0.0f}}), s);
  ASSERT_EQ(r.scan.size(), 4u);
  EXPECT_NEAR(r.scan.ranges[3], 3.0f, 1e-6);
}

// Real 32-line frames: scans cut from the two fast_gicp keyframes and matched by PLICP recover
// the planar part of fast_gicp's reference relative pose (relative.txt: x 0.486 m, y 0.106 m,
// yaw -0.62 deg).
TEST(CloudToScanTest, Hdl32ScansMatchTheReferenceMotion) {
  PLUMB_REQUIRE_DATA(target_path, "cloud3d/hdl32_pair/251370668.pcd");
  PLUMB_REQUIRE_DATA(source_path, "cloud3d/hdl32_pair/251371071.pcd");
  const PointCloud target = io::read_cloud(target_path);
  const PointCloud source = io::read_cloud(source_path);
  // The sensor is tilted ~6 deg: level both frames with the ground plane segment_frame() finds,
  // so the band is a horizontal slice 1-2.5 m above the floor (as a mounted 2D scanner would see).
  auto leveled = [](const PointCloud& frame) {
    const SegmentResult seg = segment_frame(frame);
    EXPECT_EQ(seg.status, Status::kOk);
    CloudToScanSettings s;
    const Eigen::Quaterniond q = Eigen::Quaterniond::FromTwoVectors(seg.ground.plane.normal, Eigen::Vector3d::UnitZ());
    s.T_target_sensor.linear() = q.toRotationMatrix();
    s.T_target_sensor.translation() = Eigen::Vector3d(0, 0, -seg.ground.plane.offset);  // z = height above floor
    s.min_height = 1.0;
    s.max_height = 2.5;
    s.range_min = 0.5;
    s.range_max = 30.0;
    s.angle_increment = kPi / 720;  // 0.25 deg
    return s;
  };
  const CloudToScanResult ref = cloud_to_scan(target, leveled(target));
  const CloudToScanResult cur = cloud_to_scan(source, leveled(source));
  ASSERT_EQ(ref.status, Status::kOk);
  EXPECT_GT(ref.scan.num_valid(), 800u);
  EXPECT_GT(cur.scan.num_valid(), 800u);
  PlicpSettings ps;  // start at identity, 0.5 m from the answer
  ps.max_correspondence_distance = 1.0;
  ps.max_iterations = 100;
  const PlicpResult m = plicp(cur.scan, PlicpReference(ref.scan), Pose2{0.0, 0.0, 0.0}, ps);
  ASSERT_EQ(m.status, Status::kOk);
  EXPECT_NEAR(m.T_ref_cur.x, 0.485657, 0.03);
  EXPECT_NEAR(m.T_ref_cur.y, 0.10642, 0.03);
  EXPECT_NEAR(m.T_ref_cur.theta, std::atan2(-0.0108468, 0.999941), 0.3 * kPi / 180.0);
}

}  // namespace
}  // namespace plumb
