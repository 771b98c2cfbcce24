// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/io/carmen.hpp"

#include <cmath>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "plumb/core/error.hpp"
#include "test_data.hpp"

namespace plumb::io {
namespace {


std::string error_of(const std::string& text) {
  try {
    parse_carmen(text, "bad.log");
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

// Counts from shared/data/SOURCES.md (independent of this reader).
TEST(CarmenTest, IntelCorrectedCounts) {
  PLUMB_REQUIRE_DATA(path, "laser2d/carmen_corrected/intel-corrected.log.gz");
  const CarmenLog log = read_carmen(path);
  EXPECT_EQ(log.count(CarmenLaserKind::kFlaser), 910u);
  EXPECT_EQ(log.lasers.size(), 910u);
  EXPECT_EQ(log.odometry.size(), 13700u);
  EXPECT_EQ(log.num_repeated_odometry, 14541u - 13700u);
  EXPECT_EQ(log.num_skipped, 910u);  // NEFF
  EXPECT_EQ(log.params.at("robot_frontlaser_offset"), "0.0");
  const CarmenLaser& first = log.lasers.front();
  EXPECT_EQ(first.scan.size(), 180u);
  EXPECT_NEAR(first.scan.angle(0), -kPi / 2, 1e-12);
  EXPECT_NEAR(first.scan.angle(179), kPi / 2 - kPi / 180, 1e-12);
  EXPECT_NEAR(first.ipc_timestamp, 32.9068, 1e-9);
  EXPECT_NEAR(log.lasers.back().ipc_timestamp, 2683.8, 0.05);
  // FLASER: (x, y, theta) equals the odom fields (both the corrected pose).
  for (const auto& l : log.lasers) {
    EXPECT_EQ(l.pose.x, l.odom_pose.x);
    EXPECT_EQ(l.pose.theta, l.odom_pose.theta);
  }
  EXPECT_NEAR(first.pose.x, 0.600266, 1e-12);
  EXPECT_NEAR(first.pose.theta, -0.354665, 1e-12);
  // Max-range beams (~81.83 m) are invalid.
  std::size_t num_max = 0, num_invalid = 0;
  for (const auto& l : log.lasers) {
    for (std::size_t i = 0; i < l.scan.size(); ++i) {
      num_max += l.scan.ranges[i] > 81.0f ? 1 : 0;
      num_invalid += l.scan.valid(i) ? 0 : 1;
      if (l.scan.ranges[i] > 81.0f) {
        EXPECT_FALSE(l.scan.valid(i));
      }
    }
  }
  EXPECT_GT(num_max, 0u);
  EXPECT_GE(num_invalid, num_max);
  // In this log the raw ODOM just before each FLASER carries the scan's own stamp (the stream
  // around it is not monotonic), so the prior at the scan is exactly that message's pose.
  const auto prior = raw_odometry_at_lasers(log);
  for (std::size_t k = 0; k < log.lasers.size(); ++k) {
    const CarmenOdometry& before = log.odometry[log.lasers[k].num_odometry_before - 1];
    EXPECT_EQ(before.ipc_timestamp, log.lasers[k].ipc_timestamp);
    EXPECT_NEAR(prior[k].x, before.pose.x, 1e-12);
    EXPECT_NEAR(wrap_angle(prior[k].theta - before.pose.theta), 0.0, 1e-12);
  }
}

TEST(CarmenTest, Freiburg079CorrectedCounts) {
  PLUMB_REQUIRE_DATA(path, "laser2d/carmen_corrected/freiburg-079-corrected.log.gz");
  const CarmenLog log = read_carmen(path);
  EXPECT_EQ(log.count(CarmenLaserKind::kFlaser), 4791u);
  EXPECT_EQ(log.odometry.size(), 4953u);
  EXPECT_EQ(log.lasers.front().scan.size(), 360u);
  EXPECT_NEAR(log.lasers.front().scan.angle_increment, kPi / 360, 1e-15);
  EXPECT_NEAR(log.lasers.back().ipc_timestamp, 1061.5, 0.1);
  EXPECT_EQ(log.params.size(), 187u);  // 187 PARAM lines, all with distinct names
  EXPECT_EQ(log.params.at("robot_allow_rear_motion"), "off");
}

TEST(CarmenTest, InfiniteCorridorCountsAndBrokenStamps) {
  PLUMB_REQUIRE_DATA(path, "laser2d/carmen_corrected/infinite-corridor-corrected.log.gz");
  const CarmenLog log = read_carmen(path);
  EXPECT_EQ(log.count(CarmenLaserKind::kFlaser), 1941u);
  EXPECT_EQ(log.odometry.size(), 18139u);
  bool negative = false;
  for (const auto& o : log.odometry) negative = negative || o.ipc_timestamp < 0.0;
  EXPECT_TRUE(negative);
  // Interpolation must still give one finite prior per scan despite the broken stamps.
  const auto prior = raw_odometry_at_lasers(log);
  ASSERT_EQ(prior.size(), 1941u);
  for (const auto& p : prior) EXPECT_TRUE(std::isfinite(p.x) && std::isfinite(p.theta));
}

TEST(CarmenTest, PlainTextAndGzipReadAlike) {
  PLUMB_REQUIRE_DATA(path, "laser2d/carmen_corrected/intel-corrected.log.gz");
  const CarmenLog gz = read_carmen(path);
  // A small plain-text log written here.
  const std::string plain = plumb::test::temp_path("carmen_plain.log");
  {
    std::ofstream out(plain);
    out << "# comment\nPARAM a 1 nohost 0\nODOM 1 2 0.5 0 0 0 10.0 h 10.0\n"
        << "FLASER 3 1.0 2.0 3.0 0.1 0.2 0.3 0.1 0.2 0.3 10.5 h 10.5\nNEFF 3\n"
        << "ODOM 0.1 0.2 0.3 0 0 0 0 h 0\nODOM 2 2 0.5 0 0 0 11.0 h 11.0\r\n";
  }
  const CarmenLog log = read_carmen(plain);
  ASSERT_EQ(log.lasers.size(), 1u);
  EXPECT_EQ(log.odometry.size(), 2u);
  EXPECT_EQ(log.num_repeated_odometry, 1u);
  EXPECT_EQ(log.lasers[0].line, 4u);
  EXPECT_EQ(log.lasers[0].num_odometry_before, 1u);
  EXPECT_NEAR(log.lasers[0].scan.angle_increment, kPi / 2, 1e-15);  // odd n: pi / (n - 1)
  const auto prior = raw_odometry_at_lasers(log);
  EXPECT_NEAR(prior[0].x, 1.5, 1e-12);  // halfway, straight line along x
  EXPECT_NEAR(prior[0].y, 2.0, 1e-12);
  EXPECT_NEAR(prior[0].theta, 0.5, 1e-12);
  EXPECT_GT(gz.lasers.size(), 0u);
}

TEST(CarmenTest, RawLaserAndRobotLaser) {
  const std::string text =
      "RAWLASER1 0 -1.5 3.0 0.75 20.0 0.01 0 5 1 2 3 25 4 2 0.5 0.5 7.0 host 7.0\n"
      "ROBOTLASER1 0 -1.5 3.0 0.75 80.0 0.01 0 3 1 2 3 0 1 2 0.1 4 5 0.2 0 0 0 0 0 8.0 h 8.5\n";
  const CarmenLog log = parse_carmen(text);
  ASSERT_EQ(log.lasers.size(), 2u);
  const auto& raw = log.lasers[0];
  EXPECT_EQ(raw.kind, CarmenLaserKind::kRawLaser);
  EXPECT_EQ(raw.scan.size(), 5u);
  EXPECT_DOUBLE_EQ(raw.scan.angle(2), 0.0);
  EXPECT_FALSE(raw.scan.valid(3));  // 25 m beyond the 20 m maximum
  EXPECT_TRUE(raw.scan.valid(4));
  EXPECT_DOUBLE_EQ(raw.ipc_timestamp, 7.0);
  const auto& robot = log.lasers[1];
  EXPECT_EQ(robot.kind, CarmenLaserKind::kRobotLaser);
  EXPECT_DOUBLE_EQ(robot.pose.y, 2.0);
  EXPECT_DOUBLE_EQ(robot.odom_pose.theta, 0.2);
  EXPECT_DOUBLE_EQ(robot.logger_timestamp, 8.5);
  EXPECT_DOUBLE_EQ(robot.scan.range_max, 50.0);  // capped by the settings
}

TEST(CarmenTest, MalformedLinesThrowWithLineNumber) {
  const std::string ok = "ODOM 1 2 3 0 0 0 1.0 h 1.0\n";
  // Too few ranges for the count.
  std::string e = error_of(ok + "FLASER 5 1 2 3 0 0 0 0 0 0 1.0 h 1.0\n");
  EXPECT_NE(e.find("bad.log:2"), std::string::npos) << e;
  // Not a number.
  e = error_of(ok + ok + "ODOM 1 x 3 0 0 0 1.0 h 1.0\n");
  EXPECT_NE(e.find("bad.log:3"), std::string::npos) << e;
  EXPECT_NE(e.find("'x'"), std::string::npos) << e;
  // Negative or fractional beam count.
  EXPECT_NE(error_of("FLASER -3 1 2 3\n").find("bad.log:1"), std::string::npos);
  EXPECT_NE(error_of("FLASER 2.5 1 2 3\n").find("beam count"), std::string::npos);
  // Truncated ODOM and PARAM.
  EXPECT_NE(error_of("ODOM 1 2 3\n").find("bad.log:1"), std::string::npos);
  EXPECT_NE(error_of("\n\nPARAM onlyname\n").find("bad.log:3"), std::string::npos);
  // Non-finite pose.
  EXPECT_NE(error_of("ODOM nan 2 3 0 0 0 1.0 h 1.0\n").find("finite"), std::string::npos);
  // Remission count beyond the line.
  EXPECT_NE(error_of("RAWLASER1 0 -1.5 3.0 0.75 20.0 0.01 0 2 1 2 9 1.0 h 1.0\n").find("bad.log:1"),
            std::string::npos);
  // Missing file.
  EXPECT_THROW(read_carmen("/nonexistent/file.log"), Error);
}

TEST(CarmenTest, UnknownMessagesSkipped) {
  const CarmenLog log = parse_carmen("NEFF 12\nSYNC 1 2\nRLASER 2 1 1 0 0 0 0 0 0 1 h 1\n\n   \n");
  EXPECT_EQ(log.num_skipped, 3u);
  EXPECT_TRUE(log.lasers.empty());
}

TEST(CarmenTest, InterpolatePose2IsAngleAware) {
  const Pose2 a{0.0, 0.0, kPi - 0.1}, b{0.0, 0.0, -kPi + 0.1};
  const Pose2 mid = interpolate_pose2(a, b, 0.5);
  EXPECT_NEAR(std::abs(wrap_angle(mid.theta)), kPi, 1e-12);  // through ±pi, not through 0
  const Pose2 c{1.0, 2.0, 0.3}, d{3.0, -1.0, 1.2};
  const Pose2 at0 = interpolate_pose2(c, d, 0.0), at1 = interpolate_pose2(c, d, 1.0);
  EXPECT_NEAR(at0.x, c.x, 1e-12);
  EXPECT_NEAR(at1.x, d.x, 1e-12);
  EXPECT_NEAR(at1.y, d.y, 1e-12);
  EXPECT_NEAR(wrap_angle(at1.theta - d.theta), 0.0, 1e-12);
}

TEST(CarmenTest, RawOdometryAtLasersMatchesRawStream) {
  PLUMB_REQUIRE_DATA(path, "laser2d/carmen_corrected/intel-corrected.log.gz");
  const CarmenLog log = read_carmen(path);
  const auto prior = raw_odometry_at_lasers(log);
  ASSERT_EQ(prior.size(), log.lasers.size());
  // Each interpolated prior lies between its two bracketing raw poses (within their span).
  for (std::size_t k = 0; k < prior.size(); ++k) {
    const std::size_t n = log.lasers[k].num_odometry_before;
    ASSERT_GT(n, 0u);
    ASSERT_LT(n, log.odometry.size());
    const Pose2 a = log.odometry[n - 1].pose, b = log.odometry[n].pose;
    const double span = std::hypot(b.x - a.x, b.y - a.y);
    EXPECT_LE(std::hypot(prior[k].x - a.x, prior[k].y - a.y), span + 1e-9);
  }
}

}  // namespace
}  // namespace plumb::io
