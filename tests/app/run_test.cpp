// SPDX-License-Identifier: BSD-3-Clause
// run_bim_odometry on a short simulated run in the demo office (exact ground truth).
#include "plumb/app/run.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <unistd.h>

#include <gtest/gtest.h>

#include "plumb/app/simulate.hpp"
#include "plumb/bim/bim_cloud.hpp"
#include "plumb/bim/ifc.hpp"
#include "plumb/bim/mesh.hpp"
#include "plumb/io/frame_dump.hpp"
#include "plumb/sim/scenario.hpp"
#include "model_variants.hpp"
#include "test_data.hpp"

namespace {

class BimOdometryRunTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    mesh_ = new plumb::bim::BimMesh(
        plumb::bim::build_mesh(plumb::bim::read_ifc(plumb::test::source_dir() + "/examples/data/demo_office.ifc")));
    // Per process: ctest runs the tests of this binary in parallel processes.
    dir_ = plumb::test::temp_path("bim_odometry_dump_" + std::to_string(::getpid()));
    std::filesystem::remove_all(dir_);
    plumb::sim::ScenarioSettings s = plumb::sim::scenario_defaults(plumb::sim::ScenarioKind::kIndoor);
    s.lidar = plumb::sim::lidar_preset("vlp16");
    s.length = 6.0;
    s.seed = 5;
    plumb::simulate_to_dump(*mesh_, dir_, s);
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
  EXPECT_GT(r.path_length, 5.0);
  EXPECT_LT(r.ape_rmse_bim, 0.08);
  EXPECT_LT(r.ape_rmse_lidar, 0.08);
  EXPECT_GT(r.anchors_accepted, r.bim.size() / 2);
  // The three trajectories start at the given pose.
  EXPECT_LT(xy_error(r.wheel.poses[0], gt.poses[0]), 1e-9);
  EXPECT_LT(xy_error(r.lidar.poses[0], gt.poses[0]), 1e-9);
  // The slowest frame and the median of the frames' own process() times.
  std::vector<double> seconds;
  for (const plumb::BimFrameResult& f : r.frames) seconds.push_back(f.seconds_total);
  const auto slowest = std::max_element(seconds.begin(), seconds.end());
  EXPECT_EQ(r.slowest_frame, static_cast<std::size_t>(slowest - seconds.begin()));
  EXPECT_EQ(r.max_seconds_process, *slowest);
  std::sort(seconds.begin(), seconds.end());
  EXPECT_EQ(r.median_seconds_process, seconds[seconds.size() / 2]);
  EXPECT_GT(r.median_seconds_process, 0.0);
}

TEST_F(BimOdometryRunTest, ThreadsChangeNoFrameResult) {
  // With threads, the next frame is read and deskewed ahead, each frame's key points are found
  // beside its front end and the registration's search is split: every frame's result (the as-built
  // estimate's included) is that of one thread, bit for bit.
  const plumb::io::FrameDumpReader dump(dir_);
  auto run = [&](int threads) {
    plumb::RunSettings settings;
    settings.initial_pose = dump.ground_truth().poses.front();
    settings.max_frames = 40;
    settings.odometry.estimate_as_built = true;
    settings.odometry.threads = threads;
    return plumb::run_bim_odometry(dump, *mesh_, settings);
  };
  const plumb::RunReport one = run(1);
  ASSERT_EQ(one.frames.size(), 40u);
  EXPECT_GT(one.anchors_accepted, 20u);
  for (int threads : {3}) {
    const plumb::RunReport many = run(threads);
    ASSERT_EQ(many.frames.size(), one.frames.size()) << threads;
    for (std::size_t i = 0; i < one.frames.size(); ++i) {
      const plumb::BimFrameResult& a = one.frames[i];
      const plumb::BimFrameResult& b = many.frames[i];
      ASSERT_TRUE(a.T_world_base.matrix() == b.T_world_base.matrix()) << "frame " << i << ", threads " << threads;
      ASSERT_TRUE(a.T_world_base_uncorrected.matrix() == b.T_world_base_uncorrected.matrix()) << i;
      ASSERT_TRUE(a.T_world_base_registered.matrix() == b.T_world_base_registered.matrix()) << i;
      ASSERT_EQ(a.num_key_points, b.num_key_points) << i;
      ASSERT_EQ(a.icp_inliers, b.icp_inliers) << i;
      ASSERT_EQ(a.icp_overlap, b.icp_overlap) << i;
      ASSERT_EQ(a.anchor.decision, b.anchor.decision) << i;
      ASSERT_EQ(a.as_built_pairs, b.as_built_pairs) << i;
    }
    ASSERT_EQ(many.deviations.size(), one.deviations.size());
    for (std::size_t k = 0; k < one.deviations.size(); ++k) {
      EXPECT_EQ(many.deviations[k].offset_m, one.deviations[k].offset_m) << one.deviations[k].global_id;
      EXPECT_EQ(many.deviations[k].sigma_m, one.deviations[k].sigma_m) << one.deviations[k].global_id;
    }
  }
}

TEST_F(BimOdometryRunTest, APreparedFrameGivesTheResultOfTheWholeFrame) {
  // prepare() on a second thread while process() runs is how plumb run overlaps frames; it must give
  // what process() on the whole frame gives, on the corrected frames and on the ones between.
  const plumb::io::FrameDumpReader dump(dir_);
  const plumb::Trajectory gt = dump.ground_truth();
  const auto bim = std::make_shared<const plumb::PointCloud>(plumb::bim::sample_bim_cloud(*mesh_, 0.05));
  plumb::BimOdometrySettings s;
  s.T_base_lidar = dump.meta().T_base_lidar;
  s.correct_every = 2;
  plumb::BimOdometry whole(bim, gt.poses.front(), s);
  s.threads = 2;
  plumb::BimOdometry prepared(bim, gt.poses.front(), s);
  // The front end of the next frame runs before this frame's correction (as in plumb run's pipeline).
  plumb::BimOdometry ahead(bim, gt.poses.front(), s);
  const std::size_t n = std::min<std::size_t>(dump.num_frames(), 24);
  auto odom = [&](std::size_t i) { return plumb::Pose2::from_isometry(gt.poses[i]); };
  std::optional<plumb::BimFrameInput> next = ahead.prepare(dump.frame(0), dump.stamp(0), 0);
  ahead.front_end(*next, odom(0));
  std::size_t corrected = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const plumb::PointCloud frame = dump.frame(i);
    const plumb::BimFrameResult a = whole.process(frame, dump.stamp(i), odom(i));
    const plumb::BimFrameInput in = prepared.prepare(frame, dump.stamp(i), i);
    ASSERT_EQ(in.key_points.has_value(), i % 2 == 0) << i;
    const plumb::BimFrameResult b = prepared.process(in, odom(i));
    const plumb::BimFrameInput current = std::move(*next);
    next.reset();
    if (i + 1 < n) {
      next = ahead.prepare(dump.frame(i + 1), dump.stamp(i + 1), i + 1);
      ahead.front_end(*next, odom(i + 1));
    }
    const plumb::BimFrameResult c = ahead.process(current, plumb::Pose2{1e3, 1e3, 0.0});  // odom not used
    for (const plumb::BimFrameResult* r : {&b, &c}) {
      ASSERT_TRUE(a.T_world_base.matrix() == r->T_world_base.matrix()) << "frame " << i;
      ASSERT_TRUE(a.T_world_base_uncorrected.matrix() == r->T_world_base_uncorrected.matrix()) << i;
      ASSERT_EQ(a.mode, r->mode) << i;
      ASSERT_EQ(a.anchor_attempted, r->anchor_attempted) << i;
      ASSERT_EQ(a.num_key_points, r->num_key_points) << i;
      ASSERT_EQ(a.icp_inliers, r->icp_inliers) << i;
      ASSERT_EQ(a.anchor.decision, r->anchor.decision) << i;
    }
    corrected += b.anchor.decision == plumb::AnchorDecision::kAccepted ? 1 : 0;
  }
  EXPECT_GT(corrected, n / 4);
  EXPECT_EQ(prepared.num_frames(), n);
  EXPECT_EQ(ahead.num_frames(), n);
}

TEST_F(BimOdometryRunTest, AFramePreparedForAnotherPlaceIsRefused) {
  const plumb::io::FrameDumpReader dump(dir_);
  const auto bim = std::make_shared<const plumb::PointCloud>(plumb::bim::sample_bim_cloud(*mesh_, 0.05));
  plumb::BimOdometrySettings s;
  s.T_base_lidar = dump.meta().T_base_lidar;
  plumb::BimOdometry odometry(bim, dump.ground_truth().poses.front(), s);
  const plumb::Pose2 odom;
  // Prepared as the second frame but given first: its key points would be missing or misplaced.
  EXPECT_THROW(odometry.process(odometry.prepare(dump.frame(1), dump.stamp(1), 1), odom), plumb::Error);
  EXPECT_EQ(odometry.num_frames(), 0u);
  // A frame prepared without its key points cannot be corrected.
  plumb::BimFrameInput in = odometry.prepare(dump.frame(0), dump.stamp(0), 0);
  in.key_points.reset();
  EXPECT_THROW(odometry.process(in, odom), plumb::Error);
  in.key_points = odometry.prepare(dump.frame(0), dump.stamp(0), 0).key_points;
  EXPECT_NO_THROW(odometry.process(in, odom));
  EXPECT_EQ(odometry.num_frames(), 1u);
  // The front end takes frames in order, each once.
  plumb::BimFrameInput third = odometry.prepare(dump.frame(2), dump.stamp(2), 2);
  EXPECT_THROW(odometry.front_end(third, odom), plumb::Error);
  plumb::BimFrameInput second = odometry.prepare(dump.frame(1), dump.stamp(1), 1);
  EXPECT_NO_THROW(odometry.front_end(second, odom));
  EXPECT_THROW(odometry.front_end(second, odom), plumb::Error);
  EXPECT_NO_THROW(odometry.process(second, odom));
  EXPECT_EQ(odometry.num_frames(), 2u);
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
  EXPECT_GT(lidar_end, 0.2);
  EXPECT_LT(bim_end, 0.06);
}

// The demo office as an export that leaves its ground slab to the structural model (taken out of
// the model, not out of the building the frames see): from the same known start, the BIM anchors
// hold the run as on the full model. (Finding the start in such a model:
// BimLocalizerTest.AModelWithoutFloorsLocalizesTheStartsOfTheFullBuilding.)
TEST_F(BimOdometryRunTest, AModelWithoutItsGroundSlabTracksAsTheFullOne) {
  const plumb::io::FrameDumpReader dump(dir_);
  const plumb::bim::BimMesh bare = plumb::test::without_floor_slabs(*mesh_, 0);
  ASSERT_LT(bare.num_triangles(), mesh_->num_triangles());
  plumb::RunSettings settings;
  settings.initial_pose = dump.ground_truth().poses.front();
  const plumb::RunReport full = plumb::run_bim_odometry(dump, *mesh_, settings);
  const plumb::RunReport r = plumb::run_bim_odometry(dump, bare, settings);
  ASSERT_EQ(r.bim.size(), dump.num_frames());
  EXPECT_LT(r.ape_rmse_bim, std::max(0.03, 1.5 * full.ape_rmse_bim));
  EXPECT_LT(r.max_error_bim, std::max(0.06, 1.5 * full.max_error_bim));
  EXPECT_GT(r.anchors_accepted, r.bim.size() / 2);
}

}  // namespace
