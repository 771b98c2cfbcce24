// SPDX-License-Identifier: BSD-3-Clause
// BIM-corrected odometry on a short simulated run in the demo office (exact ground truth).
#include "plumb/pipeline/bim_odometry.hpp"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>

#include <unistd.h>

#include <gtest/gtest.h>

#include "plumb/bim/ifc.hpp"
#include "plumb/bim/mesh.hpp"
#include "plumb/core/error.hpp"
#include "plumb/io/frame_dump.hpp"
#include "plumb/pipeline/run.hpp"
#include "plumb/sim/scenario.hpp"
#include "test_data.hpp"

namespace {

class BimOdometryRunTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    mesh_ = new plumb::bim::BimMesh(
        plumb::bim::build_mesh(plumb::bim::read_ifc(std::string(PLUMB_SOURCE_DIR) + "/examples/data/demo_office.ifc")));
    // Per process: ctest runs the tests of this binary in parallel processes.
    dir_ = plumb::test::temp_path("bim_odometry_dump_" + std::to_string(::getpid()));
    std::filesystem::remove_all(dir_);
    plumb::sim::ScenarioSettings s = plumb::sim::scenario_defaults(plumb::sim::ScenarioKind::kIndoor);
    s.lidar = plumb::sim::lidar_preset("vlp16");
    s.length = 6.0;
    s.seed = 5;
    plumb::sim::simulate_scenario(*mesh_, dir_, s);
  }
  static void TearDownTestSuite() {
    std::filesystem::remove_all(dir_);
    delete mesh_;
    mesh_ = nullptr;
  }
  static plumb::bim::BimMesh* mesh_;
  static std::string dir_;
};
plumb::bim::BimMesh* BimOdometryRunTest::mesh_ = nullptr;
std::string BimOdometryRunTest::dir_;

double xy_error(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return (a.translation() - b.translation()).head<2>().norm();
}

TEST_F(BimOdometryRunTest, TracksGroundTruthFromAKnownStart) {
  const plumb::io::FrameDumpReader dump(dir_);
  const plumb::Trajectory gt = dump.ground_truth();
  plumb::RunSettings settings;
  settings.initial_pose = gt.poses.front();
  const plumb::RunReport r = plumb::run_bim_odometry(dump, *mesh_, settings);
  ASSERT_EQ(r.bim.size(), dump.num_frames());
  ASSERT_TRUE(r.has_ground_truth);
  std::printf("  %zu frames, %.1f m: APE xy wheel %.3f, LiDAR %.3f, BIM %.3f m; anchors %zu/%zu accepted\n",
              r.bim.size(), r.path_length, r.ape_rmse_wheel, r.ape_rmse_lidar, r.ape_rmse_bim, r.anchors_accepted,
              r.anchors_attempted);
  EXPECT_GT(r.path_length, 5.0);
  EXPECT_LT(r.ape_rmse_bim, 0.08);
  EXPECT_LT(r.ape_rmse_lidar, 0.08);
  EXPECT_GT(r.anchors_accepted, r.bim.size() / 2);
  // The three trajectories start at the given pose.
  EXPECT_LT(xy_error(r.wheel.poses[0], gt.poses[0]), 1e-9);
  EXPECT_LT(xy_error(r.lidar.poses[0], gt.poses[0]), 1e-9);
}

TEST_F(BimOdometryRunTest, BimCorrectionRemovesAnOffsetTheFrontEndKeeps) {
  // Start 25 cm and 2 degrees off: the front end carries the offset along, the BIM anchors remove it.
  const plumb::io::FrameDumpReader dump(dir_);
  const plumb::Trajectory gt = dump.ground_truth();
  Eigen::Isometry3d off = Eigen::Isometry3d::Identity();
  off.translation() << 0.2, -0.15, 0.0;
  off.linear() = Eigen::AngleAxisd(2.0 * M_PI / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  plumb::RunSettings settings;
  settings.initial_pose = gt.poses.front() * off;
  settings.odometry.initial_covariance = plumb::Matrix6d::Identity() * 0.1;
  const plumb::RunReport r = plumb::run_bim_odometry(dump, *mesh_, settings);
  const std::size_t last = r.bim.size() - 1;
  const double bim_end = xy_error(r.bim.poses[last], gt.poses[last]);
  const double lidar_end = xy_error(r.lidar.poses[last], gt.poses[last]);
  std::printf("  end error: LiDAR only %.3f m, BIM-corrected %.3f m\n", lidar_end, bim_end);
  EXPECT_GT(lidar_end, 0.2);
  EXPECT_LT(bim_end, 0.06);
}

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
  std::vector<plumb::io::OdomSample> samples(2);
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
  EXPECT_NEAR(r1.T_bim_base.translation().x(), 0.1, 1e-9);
  EXPECT_FALSE(r0.anchor_attempted);
}

}  // namespace
