// SPDX-License-Identifier: BSD-3-Clause
// BIM-corrected odometry on a short simulated run in the demo office (exact ground truth).
#include "plumb/pipeline/bim_odometry.hpp"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include <unistd.h>

#include <gtest/gtest.h>

#include "plumb/bim/ifc.hpp"
#include "plumb/bim/mesh.hpp"
#include "plumb/core/error.hpp"
#include "plumb/io/frame_dump.hpp"
#include "plumb/pipeline/run.hpp"
#include "plumb/sim/scenario.hpp"
#include "model_variants.hpp"
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
  EXPECT_NEAR(r1.T_bim_base.translation().x(), 0.1, 1e-9);
  EXPECT_FALSE(r0.anchor_attempted);
}

}  // namespace
