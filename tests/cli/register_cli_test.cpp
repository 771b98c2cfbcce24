// SPDX-License-Identifier: BSD-3-Clause
// `plumb register`: runs the built binary on a real room scan and a moved copy of it.

#include <cmath>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "plumb/core/point_cloud.hpp"
#include "plumb/io/cloud_io.hpp"
#include "cli_runner.hpp"
#include "test_data.hpp"

namespace plumb {
namespace {

using test::CliTest;
using test::RunResult;

Eigen::Isometry3d moved_pose() {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(2.0, Vector3d(0.05, -0.03, 1.0).normalized()).toRotationMatrix();
  T.translation() = Vector3d(6.0, -3.0, 0.5);
  return T;
}

TEST_F(CliTest, RegisterRecoversMovedRoomScan) {
  PLUMB_REQUIRE_DATA(room, "cloud3d/pcl_room_scans/room_scan1.pcd");
  const Eigen::Isometry3d T_moved_room = moved_pose();
  const std::string moved_path = test::temp_path("register_cli_moved.pcd");
  io::write_cloud(moved_path, transformed(io::read_cloud(room), T_moved_room));
  const RunResult r = test::run_cli("register '" + moved_path + "' '" + room + "' --voxel 0.3 --seed 7 --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j.at("status"), "ok");
  Eigen::Matrix4d T;
  ASSERT_EQ(j.at("T_target_source").size(), 4u);
  for (int i = 0; i < 4; ++i)
    for (int c = 0; c < 4; ++c) T(i, c) = j.at("T_target_source")[static_cast<std::size_t>(i)][static_cast<std::size_t>(c)];
  // Source = moved copy, target = original: T_target_source = T_moved_room^-1.
  const Eigen::Isometry3d err = T_moved_room * Eigen::Isometry3d(T);
  EXPECT_LT(err.translation().norm(), 0.02);
  EXPECT_LT(Eigen::AngleAxisd(err.linear()).angle(), 0.2 * M_PI / 180);
  EXPECT_GT(j.at("overlap").get<double>(), 0.9);
  EXPECT_GE(j.at("rmse").get<double>(), 0.0);
  EXPECT_GT(j.at("seconds").get<double>(), 0.0);

  const RunResult text = test::run_cli("register '" + moved_path + "' '" + room + "' --voxel 0.3");
  ASSERT_EQ(text.exit_code, 0) << text.err;
  EXPECT_NE(text.out.find("T_target_source"), std::string::npos) << text.out;
  EXPECT_NE(text.out.find("status ok"), std::string::npos) << text.out;
}

TEST_F(CliTest, RegisterReportsTinyCloudsAndRejectsBadFiles) {
  PointCloud two;
  two.points = {Vector3f(0, 0, 0), Vector3f(1, 0, 0)};
  const std::string path = test::temp_path("register_cli_two.pcd");
  io::write_cloud(path, two);
  const RunResult r = test::run_cli("register '" + path + "' '" + path + "' --json");
  // The result is printed, but a failed status is exit code 3, not success.
  ASSERT_EQ(r.exit_code, 3) << r.err;
  EXPECT_EQ(nlohmann::json::parse(r.out).at("status"), "insufficient_data");
  EXPECT_NE(test::run_cli("register /nonexistent.pcd '" + path + "'").exit_code, 0);
  EXPECT_NE(test::run_cli("register '" + path + "'").exit_code, 0);
  EXPECT_NE(test::run_cli("register '" + path + "' '" + path + "' --voxel -1").exit_code, 0);
}

}  // namespace
}  // namespace plumb
