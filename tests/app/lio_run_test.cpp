// SPDX-License-Identifier: BSD-3-Clause
// run_lio(), the LiDAR/IMU odometry over a frame dump: its bookkeeping on small synthetic dumps
// (which frames start the map, counts, ground truth present, short or absent, partial runs, bad
// dumps), and on a short simulated site run around FZK-Haus its figures against the ground truth
// and against what `plumb lio` writes for the same dump.
#include "plumb/app/lio_run.hpp"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "cli_runner.hpp"
#include "plumb/core/error.hpp"
#include "plumb/core/rng.hpp"
#include "plumb/io/frame_dump.hpp"
#include "plumb/io/trajectory.hpp"
#include "sim_site_run.hpp"
#include "test_data.hpp"
#include "test_util.hpp"

namespace plumb {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

constexpr double kT0 = 100.0;  // stamp of frame 0 [s]; frames every 0.1 s

// A cloud of `n` scattered points around the sensor (no wall, no ring field).
PointCloud scattered(std::size_t n) {
  PointCloud c;
  for (std::size_t k = 0; k < n; ++k) {
    const double a = 0.3 * static_cast<double>(k);
    const double r = 5.0 + static_cast<double>(k % 7);
    c.points.emplace_back(static_cast<float>(r * std::cos(a)), static_cast<float>(r * std::sin(a)),
                          static_cast<float>(static_cast<int>(k % 5) - 2));
  }
  return c;
}

struct SyntheticDump {
  std::size_t frames = 8;
  std::size_t gt_poses = 8;  // 0: no gt.tum
  std::size_t empty_frames = 1;  // frames [0, empty_frames) hold too few points to start a map
  bool imu = false;          // a standing IMU at 200 Hz over the whole run
  bool imu_noise = false;    // ... whose readings carry white noise
};

// Frame 0 (the first empty_frames) holds 3 points (too few for a map of min_init_points 100), the
// others 150. The truth drives 0.1 m along x per frame.
std::string write_dump(const std::string& name, const SyntheticDump& d) {
  const std::string dir = test::temp_path("lio_run_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  io::FrameDumpMeta meta;
  meta.lidar.rate_hz = 10.0;
  io::FrameDumpWriter w(dir, meta);
  Trajectory gt;
  for (std::size_t i = 0; i < d.frames; ++i) {
    const double stamp = kT0 + 0.1 * static_cast<double>(i);
    w.add_frame(stamp, scattered(i < d.empty_frames ? 3 : 150));
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation() = Vector3d(0.1 * static_cast<double>(i), 2.0, 0.5);
    if (i < d.gt_poses) gt.push_back(stamp, T);
  }
  if (d.gt_poses > 0) w.write_ground_truth(gt);
  if (d.imu) {
    std::vector<ImuSample> imu;
    Rng rng(7);
    for (int k = -20; k < static_cast<int>(d.frames) * 20 + 40; ++k) {
      ImuSample s;
      s.stamp = kT0 + 0.005 * k;
      s.accel = Vector3d(0, 0, 9.81);
      if (d.imu_noise) {
        s.gyro = 0.01 * Vector3d(rng.normal(), rng.normal(), rng.normal());
        s.accel += 0.05 * Vector3d(rng.normal(), rng.normal(), rng.normal());
      }
      imu.push_back(s);
    }
    w.write_imu(imu);
  }
  w.close();
  return dir;
}

LioRunSettings loam_settings() {
  LioRunSettings s;
  s.lio.mode = LioMode::kLoam;
  s.lio.features.min_init_points = 100;
  return s;
}

TEST(LioRunTest, CountsEveryFrameAndStartsAtTheTruthOfTheFirstUsableFrame) {
  const std::string dir = write_dump("counts", {});
  const io::FrameDumpReader dump(dir);
  const Trajectory gt = dump.ground_truth();
  LioRunSettings s = loam_settings();
  std::vector<std::pair<std::size_t, std::size_t>> calls;
  s.progress = [&](std::size_t done, std::size_t total) { calls.emplace_back(done, total); };
  const LioRunReport r = run_lio(dump, s);

  ASSERT_EQ(r.frames.size(), 8u);
  EXPECT_EQ(r.frames_requested, 8u);
  EXPECT_FALSE(r.partial);
  EXPECT_TRUE(r.warnings.empty());
  ASSERT_EQ(calls.size(), 8u);
  EXPECT_EQ(calls.front(), std::make_pair(std::size_t{1}, std::size_t{8}));
  EXPECT_EQ(calls.back(), std::make_pair(std::size_t{8}, std::size_t{8}));
  // Frame 0 is too empty: skipped, and frame 1 starts the map at the truth's pose of frame 1.
  EXPECT_EQ(r.first_frame, 1u);
  EXPECT_EQ(r.frames[0].mode, LioFrameMode::kSkipped);
  EXPECT_EQ(r.frames[1].mode, LioFrameMode::kInit);
  EXPECT_EQ(r.frames_in(LioFrameMode::kSkipped), 1u);
  EXPECT_EQ(r.frames_in(LioFrameMode::kInit), 1u);
  std::size_t counted = 0, planes = 0;
  double seconds = 0.0;
  for (std::size_t m : r.frames_per_mode) counted += m;
  for (const LioFrameResult& f : r.frames) {
    planes += f.num_plane_points;
    seconds += f.seconds;
  }
  EXPECT_EQ(counted, 8u);
  EXPECT_DOUBLE_EQ(r.mean_plane_points, static_cast<double>(planes) / 8.0);
  EXPECT_DOUBLE_EQ(r.seconds_process, seconds);
  EXPECT_LE(r.median_seconds_process, r.max_seconds_process);
  ASSERT_EQ(r.trajectory.size(), 7u);
  EXPECT_EQ(r.trajectory.stamps.front(), dump.stamp(1));
  EXPECT_TRUE(r.trajectory.poses.front().isApprox(gt.poses[1], 1e-12));

  // The figures compare frames 1..7 with the truth of the same frames.
  EXPECT_TRUE(r.has_ground_truth);
  EXPECT_EQ(r.ground_truth_note, "used");
  ASSERT_TRUE(r.has_metrics);
  EXPECT_NEAR(r.path_length, 0.6, 1e-12);
  const Vector3d end = r.trajectory.poses.back().translation() - gt.poses.back().translation();
  EXPECT_NEAR(r.end_error, end.norm(), 1e-12);
  EXPECT_NEAR(r.end_error_xy, end.head<2>().norm(), 1e-12);
  double sse = 0.0, worst = 0.0;
  for (std::size_t i = 1; i < 8; ++i) {
    const double e = (r.trajectory.poses[i - 1].translation() - gt.poses[i].translation()).norm();
    sse += e * e;
    worst = std::max(worst, e);
  }
  EXPECT_NEAR(r.ape_rmse, std::sqrt(sse / 7.0), 1e-12);
  EXPECT_NEAR(r.max_error, worst, 1e-12);
  EXPECT_EQ(r.rpe_pairs, 0u);  // 0.6 m holds no 10 m step

  // max_frames: only the first frames, and the truth covers them.
  s.max_frames = 5;
  const LioRunReport five = run_lio(dump, s);
  EXPECT_EQ(five.frames.size(), 5u);
  EXPECT_EQ(five.frames_requested, 5u);
  EXPECT_EQ(calls.back(), std::make_pair(std::size_t{5}, std::size_t{5}));
  EXPECT_NEAR(five.path_length, 0.3, 1e-12);
  fs::remove_all(dir);
}

TEST(LioRunTest, ShortOrAbsentGroundTruthIsReportedNotMeasured) {
  SyntheticDump d;
  d.gt_poses = 4;
  const std::string short_dir = write_dump("short_gt", d);
  const LioRunReport r = run_lio(io::FrameDumpReader(short_dir), loam_settings());
  EXPECT_FALSE(r.has_ground_truth);
  EXPECT_EQ(r.ground_truth_note, "too_short");
  ASSERT_EQ(r.warnings.size(), 1u);
  EXPECT_NE(r.warnings[0].find(short_dir + "/gt.tum: 4 poses for 8 frames"), std::string::npos) << r.warnings[0];
  EXPECT_FALSE(r.has_metrics);
  EXPECT_EQ(r.end_error, 0.0);
  // Without the truth the start is the identity.
  ASSERT_FALSE(r.trajectory.empty());
  EXPECT_TRUE(r.trajectory.poses.front().isApprox(Eigen::Isometry3d::Identity()));
  // Four frames are covered: measured again.
  LioRunSettings four = loam_settings();
  four.max_frames = 4;
  EXPECT_TRUE(run_lio(io::FrameDumpReader(short_dir), four).has_metrics);

  d.gt_poses = 0;
  const std::string no_dir = write_dump("no_gt", d);
  const LioRunReport none = run_lio(io::FrameDumpReader(no_dir), loam_settings());
  EXPECT_EQ(none.ground_truth_note, "absent");
  EXPECT_TRUE(none.warnings.empty());
  EXPECT_FALSE(none.has_metrics);
  fs::remove_all(short_dir);
  fs::remove_all(no_dir);
}

TEST(LioRunTest, TheImuIsFedThroughEveryFrameInterval) {
  SyntheticDump d;
  d.imu = true;
  const std::string dir = write_dump("imu", d);
  LioRunSettings s = loam_settings();
  s.lio.mode = LioMode::kLoamImu;
  const LioRunReport r = run_lio(io::FrameDumpReader(dir), s);
  ASSERT_EQ(r.frames.size(), 8u);
  EXPECT_EQ(r.first_frame, 1u);
  EXPECT_EQ(r.imu_gaps, 0u);
  EXPECT_EQ(r.imu_samples_dropped, 0u);
  for (std::size_t i = 2; i < r.frames.size(); ++i) EXPECT_TRUE(r.frames[i].imu_used) << i;
  fs::remove_all(dir);
}

// run_lio() streams imu.csv and keeps only the samples a restart can still ask for. The reference
// here holds the whole log and indexes it: every estimator, the ones restarted after empty frames
// included, must get the same samples, so every pose agrees bit for bit.
TEST(LioRunTest, TheStreamedImuGivesWhatIndexingTheWholeLogGives) {
  SyntheticDump d;
  d.empty_frames = 3;
  d.imu = true;
  d.imu_noise = true;
  const std::string dir = write_dump("imu_restart", d);
  const io::FrameDumpReader dump(dir);
  LioRunSettings s = loam_settings();
  s.lio.mode = LioMode::kHybrid;
  const LioRunReport r = run_lio(dump, s);
  ASSERT_EQ(r.first_frame, 3u);

  const std::vector<ImuSample> imu = dump.imu();
  const Trajectory gt = dump.ground_truth();
  HybridLioSettings ls = s.lio;
  ls.T_base_lidar = dump.meta().T_base_lidar;
  ls.T_base_imu = dump.meta().T_base_imu;
  const double sweep = 0.1;
  std::optional<HybridLio> lio;
  std::size_t next = 0;
  Trajectory expected;
  for (std::size_t i = 0; i < dump.num_frames(); ++i) {
    const double stamp = dump.stamp(i);
    if (!lio) {
      lio.emplace(gt.poses[i], ls);
      if (i > 0) {
        next = static_cast<std::size_t>(std::lower_bound(imu.begin(), imu.end(), stamp - sweep,
                                                         [](const ImuSample& a, double t) { return a.stamp < t; }) -
                                        imu.begin());
      }
    }
    for (; next < imu.size() && imu[next].stamp <= stamp + sweep + 0.02; ++next) lio->add_imu(imu[next]);
    const LioFrameResult f = lio->process(dump.frame(i), stamp);
    if (!lio->initialized()) lio.reset();
    if (f.mode != LioFrameMode::kSkipped) expected.push_back(stamp, f.T_world_base);
    ASSERT_EQ(r.frames[i].imu_used, f.imu_used) << i;
  }
  ASSERT_EQ(r.trajectory.size(), expected.size());
  for (std::size_t k = 0; k < expected.size(); ++k) {
    EXPECT_EQ(r.trajectory.stamps[k], expected.stamps[k]) << k;
    EXPECT_TRUE(r.trajectory.poses[k].matrix() == expected.poses[k].matrix()) << k;
  }
  EXPECT_TRUE(r.frames.back().imu_used);
  fs::remove_all(dir);
}

TEST(LioRunTest, AFrameFailingAfterTheStartGivesAPartialReport) {
  const std::string dir = write_dump("partial", {});
  test::write_text(dir + "/frames/000004.pcd", "not a point cloud\n");
  const LioRunReport r = run_lio(io::FrameDumpReader(dir), loam_settings());
  EXPECT_TRUE(r.partial);
  EXPECT_EQ(r.frames.size(), 4u);
  EXPECT_EQ(r.frames_requested, 8u);
  EXPECT_EQ(r.trajectory.size(), 3u);
  EXPECT_NE(r.error.find("frame 4: "), std::string::npos) << r.error;
  EXPECT_NE(r.error.find("000004.pcd"), std::string::npos) << r.error;
  EXPECT_TRUE(r.has_metrics);  // over the frames processed
  // Before any frame started the map there is nothing to keep: the failure is thrown.
  test::write_text(dir + "/frames/000001.pcd", "not a point cloud\n");
  const std::string message = test::error_of([&] { run_lio(io::FrameDumpReader(dir), loam_settings()); });
  EXPECT_NE(message.find("000001.pcd"), std::string::npos) << message;
  fs::remove_all(dir);
}

TEST(LioRunTest, UnusableDumpsAreRefusedNamingTheProblem) {
  const std::string dir = write_dump("bad", {});
  const io::FrameDumpReader dump(dir);
  LioRunSettings s = loam_settings();
  s.lio.mode = LioMode::kHybrid;
  std::string message = test::error_of([&] { run_lio(dump, s); });
  EXPECT_NE(message.find("imu.csv"), std::string::npos) << message;
  // No frame with the points to start the map.
  s = loam_settings();
  s.lio.features.min_init_points = 1000;
  message = test::error_of([&] { run_lio(dump, s); });
  EXPECT_NE(message.find("none of the 8 frames has the 1000 points needed to start the map"), std::string::npos)
      << message;
  // gt.tum with a pose that is not at its frame's stamp.
  Trajectory gt = dump.ground_truth();
  gt.stamps[3] += 0.05;
  io::write_tum(gt, dir + "/gt.tum");
  message = test::error_of([&] { run_lio(io::FrameDumpReader(dir), loam_settings()); });
  EXPECT_NE(message.find("gt.tum: pose 3"), std::string::npos) << message;
  fs::remove_all(dir);
}

// A short simulated site run: 1 s standing, then 3 m along FZK-Haus (16-line LiDAR, 300 Hz IMU).
class LioRunSiteTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { test::simulate_fzk_site_run("lio_run_site", dir_); }
  static void TearDownTestSuite() {
    if (!dir_.empty()) fs::remove_all(dir_);
  }
  void SetUp() override { PLUMB_REQUIRE_DATA(ifc, "ifc/buildings/AC20-FZK-Haus.ifc"); }
  static std::string dir_;
};

std::string LioRunSiteTest::dir_;

TEST_F(LioRunSiteTest, HybridTracksTheTruthAndIsWhatTheCliWrites) {
  const io::FrameDumpReader dump(dir_);
  const Trajectory gt = dump.ground_truth();
  const std::size_t n = dump.num_frames();
  LioRunSettings s;
  s.lio.features.min_init_points = 100;  // as `plumb lio`
  const LioRunReport r = run_lio(dump, s);
  ASSERT_EQ(r.frames.size(), n);
  EXPECT_EQ(r.first_frame, 0u);
  EXPECT_EQ(r.frames_in(LioFrameMode::kSkipped), 0u);
  EXPECT_EQ(r.frames_in(LioFrameMode::kLoam) + r.frames_in(LioFrameMode::kIcp), n - 1);
  EXPECT_EQ(r.imu_gaps, 0u);
  ASSERT_EQ(r.trajectory.size(), n);
  ASSERT_TRUE(r.has_metrics);
  // Against the truth: the same figures by hand, and failure bounds over the ~3 m driven.
  const Vector3d end = r.trajectory.poses.back().translation() - gt.poses[n - 1].translation();
  EXPECT_NEAR(r.end_error, end.norm(), 1e-12);
  EXPECT_LT(r.end_error, 0.3);
  EXPECT_LT(r.ape_rmse, 0.3);
  EXPECT_LE(r.ape_rmse, r.max_error);
  double path = 0.0;
  for (std::size_t i = 1; i < n; ++i) path += (gt.poses[i].translation() - gt.poses[i - 1].translation()).norm();
  EXPECT_NEAR(r.path_length, path, 1e-9);
  EXPECT_NEAR(r.path_length, 3.0, 0.5);

  // `plumb lio` on the same dump writes this trajectory and these figures.
  if (!test::file_exists(test::cli_binary())) GTEST_SKIP() << "plumb CLI not built: " << test::cli_binary();
  const std::string out = test::temp_path("lio_run_site_out_" + std::to_string(::getpid()));
  fs::remove_all(out);
  const test::RunResult cli = test::run_cli("lio '" + dir_ + "' --mode hybrid -o '" + out + "'");
  ASSERT_EQ(cli.exit_code, 0) << cli.err;
  const std::string mine = out + "/mine.tum";
  io::write_tum(r.trajectory, mine);
  EXPECT_EQ(test::read_text(out + "/trajectory.tum"), test::read_text(mine));
  const Json j = Json::parse(test::read_text(out + "/report.json"));
  EXPECT_EQ(j.at("frames").get<std::size_t>(), r.frames.size());
  EXPECT_EQ(j.at("first_frame").get<std::size_t>(), r.first_frame);
  EXPECT_EQ(j.at("ground_truth").get<std::string>(), r.ground_truth_note);
  const Json& modes = j.at("frames_per_mode");
  EXPECT_EQ(modes.at("init").get<std::size_t>(), r.frames_in(LioFrameMode::kInit));
  EXPECT_EQ(modes.at("loam").get<std::size_t>(), r.frames_in(LioFrameMode::kLoam));
  EXPECT_EQ(modes.at("icp").get<std::size_t>(), r.frames_in(LioFrameMode::kIcp));
  EXPECT_EQ(modes.at("prediction").get<std::size_t>(), r.frames_in(LioFrameMode::kPrediction));
  EXPECT_EQ(j.at("failures").at("not_converged").get<std::size_t>(), r.not_converged);
  EXPECT_EQ(j.at("features").at("mean_plane_points").get<double>(), r.mean_plane_points);
  EXPECT_EQ(j.at("path_length").get<double>(), r.path_length);
  EXPECT_EQ(j.at("end_error").get<double>(), r.end_error);
  EXPECT_EQ(j.at("end_error_xy").get<double>(), r.end_error_xy);
  EXPECT_EQ(j.at("ape_rmse").get<double>(), r.ape_rmse);
  EXPECT_FALSE(j.contains("rpe_10m"));  // no 10 m step in 3 m, as r.rpe_pairs says
  EXPECT_EQ(r.rpe_pairs, 0u);
  fs::remove_all(out);
}

}  // namespace
}  // namespace plumb
