// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/io/trajectory.hpp"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "plumb/core/error.hpp"
#include "plumb/core/lie.hpp"
#include "plumb/core/rng.hpp"
#include "test_data.hpp"
#include "test_util.hpp"

namespace plumb {
namespace {

std::string write_file(const std::string& name, const std::string& text) {
  const std::string path = test::temp_path("traj_" + name);
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << text;
  return path;
}

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

Trajectory random_trajectory(std::size_t n, std::uint64_t seed) {
  Rng rng(seed);
  Trajectory t;
  for (std::size_t i = 0; i < n; ++i) {
    const Vector3d phi(rng.uniform(-3, 3), rng.uniform(-3, 3), rng.uniform(-3, 3));
    const Vector3d p(rng.uniform(-500, 500), rng.uniform(-500, 500), rng.uniform(-5, 5));
    t.push_back(1.6e9 + 0.1 * static_cast<double>(i) + rng.uniform(0, 1e-3), se3::make(so3::exp(phi), p));
  }
  return t;
}

TEST(TumTest, ReadsCommentsBlankLinesAndCrlf) {
  const std::string path = write_file("crlf.tum",
                                      "# timestamp tx ty tz qx qy qz qw\r\n"
                                      "\r\n"
                                      "1.5 1 2 3 0 0 0 1\r\n"
                                      "   \t\r\n"
                                      "  2.5\t4 5 6 0 0 0.7071067811865476 0.7071067811865476  \r\n"
                                      "# trailing comment\n"
                                      "3.5 7 8 9 1 0 0 0");  // no final newline
  const Trajectory t = io::read_tum(path);
  ASSERT_EQ(t.size(), 3u);
  ASSERT_TRUE(t.has_stamps());
  EXPECT_EQ(t.stamps[0], 1.5);
  EXPECT_EQ(t.stamps[2], 3.5);
  EXPECT_EQ(t.poses[1].translation(), Vector3d(4, 5, 6));
  // 90 deg about z maps x to y.
  EXPECT_NEAR((t.poses[1].linear() * Vector3d::UnitX() - Vector3d::UnitY()).norm(), 0.0, 1e-15);
  // 180 deg about x.
  EXPECT_NEAR((t.poses[2].linear() - Vector3d(1, -1, -1).asDiagonal().toDenseMatrix()).norm(), 0.0, 1e-15);
}

TEST(TumTest, RoundTripIsLossless) {
  const Trajectory t = random_trajectory(200, 7);
  const std::string path = test::temp_path("traj_roundtrip.tum");
  io::write_tum(t, path);
  const Trajectory back = io::read_tum(path);
  ASSERT_EQ(back.size(), t.size());
  for (std::size_t i = 0; i < t.size(); ++i) {
    EXPECT_EQ(back.stamps[i], t.stamps[i]) << i;  // bit-identical
    EXPECT_EQ(back.poses[i].translation(), t.poses[i].translation()) << i;
    EXPECT_LT((back.poses[i].linear() - t.poses[i].linear()).cwiseAbs().maxCoeff(), 1e-15) << i;
  }
}

TEST(TumTest, NormalizesNearlyUnitQuaternion) {
  // Printed with 4 decimals: |q| = 1.00007.
  const std::string path = write_file("near_unit.tum", "0 0 0 0 0.7071 0 0 0.7072\n");
  const Trajectory t = io::read_tum(path);
  const Matrix3d R = t.poses[0].linear();
  EXPECT_LT((R.transpose() * R - Matrix3d::Identity()).norm(), 1e-14);
  EXPECT_NEAR(R.determinant(), 1.0, 1e-14);
}

TEST(TumTest, FarFromUnitQuaternionThrowsNamingLine) {
  const std::string path = write_file("far_quat.tum", "# c\n0 0 0 0 0 0 0 1\n1 0 0 0 0.5 0 0 0.5\n");
  const std::string message = test::error_of([&] { io::read_tum(path); });
  EXPECT_NE(message.find(path + ":3:"), std::string::npos) << message;
  EXPECT_NE(message.find("quaternion"), std::string::npos) << message;
}

TEST(TumTest, ZeroQuaternionThrows) {
  const std::string path = write_file("zero_quat.tum", "0 1 2 3 0 0 0 0\n");
  EXPECT_NE(test::error_of([&] { io::read_tum(path); }).find(path + ":1:"), std::string::npos);
}

TEST(TumTest, WrongFieldCountThrowsNamingLine) {
  const std::string path = write_file("short.tum", "0 0 0 0 0 0 0 1\n\n1 0 0 0 0 0 1\n");
  const std::string message = test::error_of([&] { io::read_tum(path); });
  EXPECT_NE(message.find(path + ":3:"), std::string::npos) << message;
  EXPECT_NE(message.find("expected 8 fields"), std::string::npos) << message;
  const std::string longer = write_file("long.tum", "0 0 0 0 0 0 0 1 9\n");
  EXPECT_NE(test::error_of([&] { io::read_tum(longer); }).find(longer + ":1:"), std::string::npos);
}

TEST(TumTest, NonNumericAndNonFiniteFieldsThrow) {
  for (const char* bad : {"0 0 x 0 0 0 0 1\n", "0 0 1.5e 0 0 0 0 1\n", "0 nan 0 0 0 0 0 1\n",
                          "inf 0 0 0 0 0 0 1\n", "0 0 0 0 0 0 0 1e999\n"}) {
    const std::string path = write_file("nonnumeric.tum", bad);
    const std::string message = test::error_of([&] { io::read_tum(path); });
    EXPECT_NE(message.find(path + ":1:"), std::string::npos) << bad << " -> " << message;
  }
}

TEST(TumTest, EmptyAndMissingFilesThrow) {
  const std::string empty = write_file("empty.tum", "");
  EXPECT_NE(test::error_of([&] { io::read_tum(empty); }).find(empty), std::string::npos);
  const std::string comments = write_file("comments.tum", "# only\n\n# comments\r\n");
  EXPECT_NE(test::error_of([&] { io::read_tum(comments); }).find("no poses"), std::string::npos);
  const std::string missing = test::temp_path("traj_does_not_exist.tum");
  std::remove(missing.c_str());
  EXPECT_NE(test::error_of([&] { io::read_tum(missing); }).find(missing), std::string::npos);
}

TEST(TumTest, WriteWithoutStampsThrows) {
  Trajectory t;
  t.poses.push_back(Eigen::Isometry3d::Identity());
  EXPECT_THROW(io::write_tum(t, test::temp_path("traj_nostamps.tum")), Error);
}

TEST(KittiTest, RoundTripWithTimesIsLossless) {
  const Trajectory t = random_trajectory(100, 11);
  const std::string path = test::temp_path("traj_roundtrip.kitti");
  const std::string times = test::temp_path("traj_roundtrip_times.txt");
  io::write_kitti(t, path, times);
  io::TrajectoryReadSettings keep;
  keep.orthonormalize = false;
  const Trajectory back = io::read_kitti(path, times, keep);
  ASSERT_EQ(back.size(), t.size());
  for (std::size_t i = 0; i < t.size(); ++i) {
    EXPECT_EQ(back.stamps[i], t.stamps[i]);
    EXPECT_EQ(back.poses[i].matrix(), t.poses[i].matrix()) << i;  // bit-identical
  }
  const Trajectory no_times = io::read_kitti(path);
  EXPECT_FALSE(no_times.has_stamps());
  EXPECT_EQ(no_times.size(), t.size());
}

TEST(KittiTest, ReadsRealGroundTruthAndTimes) {
  PLUMB_REQUIRE_DATA(gt, "trajectories/kitti00/KITTI_00_gt.txt");
  PLUMB_REQUIRE_DATA(times, "trajectories/kitti00/KITTI_00_gt_times.txt");
  const Trajectory t = io::read_kitti(gt, times);
  ASSERT_EQ(t.size(), 4541u);  // SOURCES.md
  EXPECT_EQ(t.stamps[1], 1.037359e-01);
  // Line 2 of the file, as printed.
  EXPECT_NEAR(t.poses[1].translation().z(), 8.586941e-01, 0.0);
  for (const auto& T : t.poses) {
    EXPECT_LT((T.linear().transpose() * T.linear() - Matrix3d::Identity()).cwiseAbs().maxCoeff(), 1e-14);
  }
}

TEST(KittiTest, ReorthonormalizesSmallRotationErrors) {
  // Rotation about z by 0.3 rad printed with 6 decimals.
  const double c = std::cos(0.3), s = std::sin(0.3);
  char line[256];
  std::snprintf(line, sizeof(line), "%.6f %.6f 0 1 %.6f %.6f 0 2 0 0 1.000001 3\n", c, -s, s, c);
  const std::string path = write_file("small_error.kitti", line);
  const Trajectory t = io::read_kitti(path);
  const Matrix3d R = t.poses[0].linear();
  EXPECT_LT((R.transpose() * R - Matrix3d::Identity()).cwiseAbs().maxCoeff(), 1e-15);
  EXPECT_NEAR(R.determinant(), 1.0, 1e-15);
  EXPECT_LT((R - Eigen::AngleAxisd(0.3, Vector3d::UnitZ()).toRotationMatrix()).norm(), 2e-6);
  EXPECT_EQ(t.poses[0].translation(), Vector3d(1, 2, 3));
  // Kept as printed when asked.
  io::TrajectoryReadSettings keep;
  keep.orthonormalize = false;
  EXPECT_EQ(io::read_kitti(path, "", keep).poses[0].linear()(2, 2), 1.000001);
}

TEST(KittiTest, NonRotationThrowsNamingLine) {
  const std::string ok = "1 0 0 0 0 1 0 0 0 0 1 0\n";
  // Scaled by 1.1, a shear, and a reflection (orthonormal but det -1).
  for (const char* bad : {"1.1 0 0 0 0 1.1 0 0 0 0 1.1 0\n", "1 0.2 0 0 0 1 0 0 0 0 1 0\n",
                          "1 0 0 0 0 1 0 0 0 0 -1 0\n", "0 0 0 0 0 0 0 0 0 0 0 0\n"}) {
    const std::string path = write_file("bad_rotation.kitti", ok + "\r\n" + bad);
    const std::string message = test::error_of([&] { io::read_kitti(path); });
    EXPECT_NE(message.find(path + ":3:"), std::string::npos) << bad << " -> " << message;
    EXPECT_NE(message.find("rotation"), std::string::npos) << message;
  }
}

TEST(KittiTest, MalformedLinesThrowNamingLine) {
  const std::string ok = "1 0 0 0 0 1 0 0 0 0 1 0\n";
  for (const char* bad : {"1 0 0 0 0 1 0 0 0 0 1\n", "1 0 0 0 0 1 0 0 0 0 1 0 5\n", "1 0 0 0 0 1 0 0 0 0 1 abc\n"}) {
    const std::string path = write_file("malformed.kitti", ok + ok + bad);
    EXPECT_NE(test::error_of([&] { io::read_kitti(path); }).find(path + ":3:"), std::string::npos) << bad;
  }
}

TEST(KittiTest, TimesCountMismatchAndBadTimesThrow) {
  const std::string path = write_file("two.kitti", "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 1 0 1 0 0 0 0 1 0\n");
  const std::string three = write_file("three_times.txt", "0\n0.1\n0.2\n");
  EXPECT_NE(test::error_of([&] { io::read_kitti(path, three); }).find(three), std::string::npos);
  const std::string bad = write_file("bad_times.txt", "0\n0.1 0.2\n");
  EXPECT_NE(test::error_of([&] { io::read_kitti(path, bad); }).find(bad + ":2:"), std::string::npos);
  const std::string empty = write_file("empty.kitti", "\n\n");
  EXPECT_NE(test::error_of([&] { io::read_kitti(empty); }).find(empty), std::string::npos);
  EXPECT_THROW(io::read_kitti(test::temp_path("traj_missing.kitti")), Error);
}

TEST(KittiTest, WriteFormatIsTwelveNumbersPerLine) {
  Trajectory t;
  t.poses.push_back(se3::make(Matrix3d::Identity(), Vector3d(0.1, -2.0, 3e-20)));
  const std::string path = test::temp_path("traj_format.kitti");
  io::write_kitti(t, path);
  EXPECT_EQ(read_file(path), "1 0 0 0.1 0 1 0 -2 0 0 1 3e-20\n");
}

}  // namespace
}  // namespace plumb
