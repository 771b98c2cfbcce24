// SPDX-License-Identifier: BSD-3-Clause
// LiDAR/IMU hybrid odometry (Zhou et al. 2021) on a short simulated `site` run around FZK-Haus (16-line
// LiDAR, 300 Hz MEMS IMU, exact ground truth from the simulator), and on degenerate input.
#include "plumb/pipeline/hybrid_lio.hpp"

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "plumb/app/simulate.hpp"
#include "plumb/bim/ifc.hpp"
#include "plumb/bim/mesh.hpp"
#include "plumb/core/error.hpp"
#include "plumb/io/frame_dump.hpp"
#include "plumb/sim/scenario.hpp"
#include "test_data.hpp"

namespace plumb {
namespace {

struct SiteRun {
  std::vector<PointCloud> frames;
  std::vector<double> stamps;
  std::vector<ImuSample> imu;
  Trajectory gt;
  io::FrameDumpMeta meta;
};

class HybridLioSiteTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    const std::string ifc = test::data_path("ifc/buildings/AC20-FZK-Haus.ifc");
    if (!test::file_exists(ifc)) return;
    const std::string dir = test::temp_path("hybrid_lio_site_" + std::to_string(::getpid()));
    std::filesystem::remove_all(dir);
    sim::ScenarioSettings s = sim::scenario_defaults(sim::ScenarioKind::kSite);
    s.length = 10.0;  // 1 s standing, then 10 m along the house's south side
    s.seed = 3;
    simulate_to_dump(bim::build_mesh(bim::read_ifc(ifc)), dir, s);
    const io::FrameDumpReader dump(dir);
    run_ = new SiteRun;
    for (std::size_t i = 0; i < dump.num_frames(); ++i) {
      run_->frames.push_back(dump.frame(i));
      run_->stamps.push_back(dump.stamp(i));
    }
    run_->imu = dump.imu();
    run_->gt = dump.ground_truth();
    run_->meta = dump.meta();
    std::filesystem::remove_all(dir);
  }
  static void TearDownTestSuite() {
    delete run_;
    run_ = nullptr;
  }
  void SetUp() override {
    PLUMB_REQUIRE_DATA(ifc, "ifc/buildings/AC20-FZK-Haus.ifc");
    ASSERT_NE(run_, nullptr);
  }

  static HybridLioSettings settings(LioMode mode) {
    HybridLioSettings s;
    s.mode = mode;
    s.T_base_lidar = run_->meta.T_base_lidar;
    s.T_base_imu = run_->meta.T_base_imu;
    return s;
  }

  /// Runs the estimator over the first `n` frames (0 = all), the IMU fed up to each sweep's end.
  static std::vector<LioFrameResult> run(const HybridLioSettings& s, std::size_t n = 0) {
    HybridLio lio(run_->gt.poses.front(), s);
    std::vector<LioFrameResult> out;
    std::size_t k = 0;
    if (n == 0) n = run_->frames.size();
    for (std::size_t i = 0; i < n; ++i) {
      while (k < run_->imu.size() && run_->imu[k].stamp <= run_->stamps[i] + 0.12) lio.add_imu(run_->imu[k++]);
      out.push_back(lio.process(run_->frames[i], run_->stamps[i]));
    }
    return out;
  }

  static double position_error(const LioFrameResult& r, std::size_t i) {
    return (r.T_world_base.translation() - run_->gt.poses[i].translation()).norm();
  }
  static double yaw_error_deg(const LioFrameResult& r, std::size_t i) {
    const Eigen::AngleAxisd aa(r.T_world_base.linear().transpose() * run_->gt.poses[i].linear());
    return aa.angle() * 180.0 / 3.14159265358979323846;
  }

  static SiteRun* run_;
};

SiteRun* HybridLioSiteTest::run_ = nullptr;

TEST_F(HybridLioSiteTest, EveryModeStaysNearTheGroundTruth) {
  const double path = 10.0;
  // Bounds over the 10 m driven along the house, ~1.5x what was measured (Release): LiDAR only
  // 1.06 m at the end, worst 1.27 m, yaw 1.9 deg (no deskew at up to 1.5 m/s, constant-velocity
  // prediction); loam-imu 0.44 m, worst 0.56 m, yaw 1.1 deg; the hybrid finds hundreds of wall
  // planes in every frame here, so it runs LOAM throughout and equals loam-imu. A broken deskew,
  // Jacobian or prior sends the estimate metres away within a few frames. (Since the map planes are
  // fitted on 10 neighbours within 5 cm, Release measures much less: LiDAR only 0.025 m at the end,
  // worst 0.156 m; loam-imu 0.033 m, worst 0.056 m. The bounds stay where they were.)
  const struct {
    LioMode mode;
    double max_end, max_any, max_yaw_deg;
  } cases[] = {{LioMode::kLoam, 0.15 * path, 0.18 * path, 3.0},
               {LioMode::kLoamImu, 0.07 * path, 0.08 * path, 1.6},
               {LioMode::kHybrid, 0.07 * path, 0.08 * path, 1.6}};
  for (const auto& c : cases) {
    SCOPED_TRACE(to_string(c.mode));
    const std::vector<LioFrameResult> r = run(settings(c.mode));
    ASSERT_EQ(r.size(), run_->frames.size());
    EXPECT_EQ(r.front().mode, LioFrameMode::kInit);
    double worst = 0.0;
    std::size_t used_lidar = 0;
    for (std::size_t i = 0; i < r.size(); ++i) {
      worst = std::max(worst, position_error(r[i], i));
      used_lidar += (r[i].mode == LioFrameMode::kLoam || r[i].mode == LioFrameMode::kIcp) ? 1 : 0;
      EXPECT_EQ(r[i].imu_used, c.mode != LioMode::kLoam && i > 0) << "frame " << i;
      EXPECT_FALSE(r[i].imu_gap);
    }
    EXPECT_EQ(used_lidar, r.size() - 1);
    const std::size_t last = r.size() - 1;
    EXPECT_LT(position_error(r[last], last), c.max_end);
    EXPECT_LT(worst, c.max_any);
    EXPECT_LT(yaw_error_deg(r[last], last), c.max_yaw_deg);
  }
}

TEST_F(HybridLioSiteTest, StandingStillTheImuModesStayPut) {
  // The robot stands for 1 s before it drives off: the first 10 frames have one true pose.
  for (LioMode mode : {LioMode::kLoamImu, LioMode::kHybrid}) {
    const std::vector<LioFrameResult> r = run(settings(mode), 9);
    for (std::size_t i = 0; i < r.size(); ++i) {
      EXPECT_LT(position_error(r[i], i), 0.05) << to_string(mode) << " frame " << i;
      EXPECT_LT(r[i].v_world.norm(), 0.15) << to_string(mode) << " frame " << i;
    }
  }
}

TEST_F(HybridLioSiteTest, HybridSwitchFollowsThePlanePointCount) {
  HybridLioSettings s = settings(LioMode::kHybrid);
  const std::size_t n = 40;
  // The switch as configured: frames below the threshold use ICP, the others LOAM (a LOAM frame
  // without enough map correspondences would also fall to ICP: not expected on this run).
  // Default: the count is the frame's non-flat plane residuals against the map (walls in view of
  // the house: hundreds); with switch_on_plane_matches off, the selected plane features off the
  // ground (30..50 per frame here, so both branches run).
  for (bool on_matches : {true, false}) {
    SCOPED_TRACE(on_matches ? "switch on plane matches" : "switch on plane features");
    s.features.switch_on_plane_matches = on_matches;
    const std::vector<LioFrameResult> r = run(s, n);
    std::size_t icp = 0, loam = 0;
    for (std::size_t i = 1; i < r.size(); ++i) {
      const std::size_t count = on_matches ? r[i].num_structure_matches : r[i].num_structure_planes;
      const bool few = count < s.features.min_plane_points;
      EXPECT_EQ(r[i].mode, few ? LioFrameMode::kIcp : LioFrameMode::kLoam) << "frame " << i;
      EXPECT_LE(r[i].num_structure_planes, r[i].num_plane_points);
      icp += r[i].mode == LioFrameMode::kIcp ? 1 : 0;
      loam += r[i].mode == LioFrameMode::kLoam ? 1 : 0;
    }
    EXPECT_EQ(icp + loam, n - 1);
    if (!on_matches) {
      EXPECT_GT(icp, 0u);
      EXPECT_GT(loam, 0u);
    }
  }
  s.features.switch_on_plane_matches = true;
  // A threshold above every frame's count: ICP throughout; 0: LOAM throughout.
  s.features.min_plane_points = 100000;
  for (const LioFrameResult& f : run(s, 15)) {
    if (f.mode != LioFrameMode::kInit) {
      EXPECT_EQ(f.mode, LioFrameMode::kIcp);
    }
  }
  s.features.min_plane_points = 0;
  for (const LioFrameResult& f : run(s, 15)) {
    if (f.mode != LioFrameMode::kInit) {
      EXPECT_EQ(f.mode, LioFrameMode::kLoam);
    }
  }
  // loam-imu never switches, whatever the count.
  HybridLioSettings li = settings(LioMode::kLoamImu);
  li.features.min_plane_points = 100000;
  for (const LioFrameResult& f : run(li, 15)) {
    if (f.mode != LioFrameMode::kInit) {
      EXPECT_EQ(f.mode, LioFrameMode::kLoam);
    }
  }
}

TEST_F(HybridLioSiteTest, GroundPlaneTakesTheRoadThePairTestMisses) {
  // The estimator's ground (classify_ground(), tested exactly in tests/loam/ground_test.cpp) on
  // simulated frames: the site's road is flat and the robot level, so a return is on the road
  // when it lies the LiDAR's mounting height below the sensor, a count independent of the
  // estimator. With the plane nearly every road return is ground; the pair test's share is what
  // the pair-only run finds.
  const double h = run_->meta.T_base_lidar.translation().z();
  HybridLioSettings s = settings(LioMode::kLoamImu);
  const std::size_t n = 30;
  const std::vector<LioFrameResult> with_plane = run(s, n);
  s.features.ground_plane_tolerance = 0.0;
  const std::vector<LioFrameResult> pair_only = run(s, n);
  std::size_t road_total = 0, found_plane = 0, found_pair = 0;
  for (std::size_t i = 0; i < n; ++i) {
    std::size_t road = 0;
    for (const Vector3f& p : run_->frames[i].points) road += std::abs(p.z() + h) < 0.05 ? 1 : 0;
    EXPECT_EQ(pair_only[i].num_ground_added, 0u) << "frame " << i;
    // The pair test's share is the same in both runs (up to returns whose slope test flips with the
    // slightly different roll and pitch estimates).
    EXPECT_NEAR(static_cast<double>(with_plane[i].num_ground - with_plane[i].num_ground_added),
                static_cast<double>(pair_only[i].num_ground), 0.01 * static_cast<double>(pair_only[i].num_ground))
        << "frame " << i;
    EXPECT_GE(static_cast<double>(with_plane[i].num_ground), 0.98 * static_cast<double>(road)) << "frame " << i;
    road_total += road;
    found_plane += with_plane[i].num_ground;
    found_pair += pair_only[i].num_ground;
  }
}

TEST_F(HybridLioSiteTest, ImuGapFallsBackAndRecovers) {
  HybridLioSettings s = settings(LioMode::kHybrid);
  HybridLio lio(run_->gt.poses.front(), s);
  const std::size_t n = std::min<std::size_t>(60, run_->frames.size());
  // No IMU sample between 2.0 s and 3.0 s.
  std::size_t k = 0, gaps = 0;
  LioFrameResult last;
  for (std::size_t i = 0; i < n; ++i) {
    while (k < run_->imu.size() && run_->imu[k].stamp <= run_->stamps[i] + 0.12) {
      const ImuSample& m = run_->imu[k++];
      if (m.stamp < 2.0 || m.stamp > 3.0) {
        EXPECT_EQ(lio.add_imu(m), Status::kOk);
      }
    }
    last = lio.process(run_->frames[i], run_->stamps[i]);
    if (last.imu_gap) {
      ++gaps;
      EXPECT_FALSE(last.imu_used);
      EXPECT_NE(last.mode, LioFrameMode::kSkipped);
    }
  }
  EXPECT_GE(gaps, 8u);
  EXPECT_LE(gaps, 13u);
  EXPECT_FALSE(last.imu_gap);
  EXPECT_TRUE(last.imu_used);
  EXPECT_LT(position_error(last, n - 1), 1.5);
}

TEST_F(HybridLioSiteTest, ImuGapDeskewsWithTheMeanTwistOfRecentFrames) {
  // No IMU between 3.0 and 4.0 s, driving at ~1.4 m/s: the frames whose sweep falls into the gap
  // are deskewed with constant velocity. With the mean twist of the last five intervals (the default) the gap's worst error is
  // lower than with the last interval alone, whose error feeds back into the next frame's deskew and
  // grows from frame to frame, and lower than leaving the gap's frames distorted. Measured (Release):
  // worst 0.050 m with five intervals, 0.072 m with one, 0.110 m without deskew.
  const std::size_t n = std::min<std::size_t>(45, run_->frames.size());
  auto worst_in_gap = [&](std::size_t twist_frames, bool deskew_gap) {
    HybridLioSettings s = settings(LioMode::kHybrid);
    s.motion.twist_frames = twist_frames;
    HybridLio lio(run_->gt.poses.front(), s);
    std::size_t k = 0, gaps = 0;
    double worst = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      while (k < run_->imu.size() && run_->imu[k].stamp <= run_->stamps[i] + 0.12) {
        const ImuSample& m = run_->imu[k++];
        if (m.stamp < 3.0 || m.stamp > 4.0) lio.add_imu(m);
      }
      PointCloud frame = run_->frames[i];
      // Frames whose interval or sweep (< 0.12 s) touches the gap.
      const bool near_gap = run_->stamps[i] + 0.12 >= 3.0 && run_->stamps[i] - 0.12 <= 4.0;
      if (near_gap && !deskew_gap) frame.times.clear();  // no per-point times: left as fired
      const LioFrameResult r = lio.process(frame, run_->stamps[i]);
      gaps += r.imu_gap ? 1 : 0;
      if (!near_gap) {
        EXPECT_TRUE(i == 0 || (r.imu_used && r.deskewed_with_imu)) << "frame " << i;
        continue;
      }
      if (r.imu_gap) {
        EXPECT_FALSE(r.deskewed_with_imu) << "frame " << i;
      }
      if (!r.deskewed_with_imu) {
        EXPECT_EQ(r.deskewed, deskew_gap) << "frame " << i;
      }
      worst = std::max(worst, position_error(r, i));
    }
    EXPECT_GE(gaps, 8u);
    return worst;
  };
  const double mean5 = worst_in_gap(5, true), last1 = worst_in_gap(1, true), none = worst_in_gap(5, false);
  EXPECT_LT(mean5, 0.85 * last1);
  EXPECT_LT(mean5, 0.8 * none);
  EXPECT_LT(mean5, 0.08);
}

TEST_F(HybridLioSiteTest, LidarOnlyPredictsWithTheMeanTwistOfRecentFrames) {
  // LiDAR only; in four windows of five frames the LiDAR returns almost nothing, so those frames
  // are the constant-velocity prediction alone: the previous pose moved on by the mean body twist
  // of the last `twist_frames` intervals (of the IMU frame, as the estimator keeps its state).
  const std::size_t n = run_->frames.size();
  PointCloud blank;
  blank.points = {Vector3f(1, 2, 0), Vector3f(5, -3, 1), Vector3f(-4, 0.5f, 0.2f)};
  const Eigen::Isometry3d T_base_imu = run_->meta.T_base_imu;
  auto drift = [&](std::size_t twist_frames) {
    HybridLioSettings s = settings(LioMode::kLoam);
    s.motion.twist_frames = twist_frames;
    HybridLio lio(run_->gt.poses.front(), s);
    std::vector<Eigen::Isometry3d> imu_poses;
    double total = 0.0, before = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      const std::size_t phase = i % (n / 4);
      const bool lost = phase >= n / 8 && phase < n / 8 + 5;
      const LioFrameResult r = lio.process(lost ? blank : run_->frames[i], run_->stamps[i]);
      imu_poses.push_back(r.T_world_base * T_base_imu);
      if (lost) {
        EXPECT_EQ(r.mode, LioFrameMode::kPrediction) << "frame " << i;
        const std::size_t j = i - 1, j0 = i - 1 - std::min(twist_frames, i - 1);
        const Vector6d twist = se3::log(imu_poses[j0].inverse() * imu_poses[j]) / (run_->stamps[j] - run_->stamps[j0]);
        const Eigen::Isometry3d expected = imu_poses[j] * se3::exp(twist * (run_->stamps[i] - run_->stamps[j]));
        EXPECT_LT((expected.translation() - imu_poses[i].translation()).norm(), 1e-6) << "frame " << i;
        EXPECT_LT(Eigen::AngleAxisd(expected.linear().transpose() * imu_poses[i].linear()).angle(), 1e-6) << "frame " << i;
      }
      if (phase == n / 8 - 1) before = position_error(r, i);
      if (phase == n / 8 + 4) total += position_error(r, i) - before;
    }
    return total;
  };
  // What the five lost frames add to the error, summed over the windows. Here (near the house, the
  // registration well constrained, the robot speeding up to 1.5 m/s and braking) the last interval
  // bridges them better: a mean lags a changing speed. Measured (Release): 0.276 m with five
  // intervals, 0.151 m with one. On whole site routes the registration is noisy along the road and
  // the mean wins by far (site runs: docs/results.md). A broken prediction goes metres off.
  const double mean5 = drift(5), last1 = drift(1);
  EXPECT_LT(mean5, 0.5);
  EXPECT_LT(last1, 0.5);
}

TEST_F(HybridLioSiteTest, AnEmptyFirstFrameIsSkippedAndTheNextStartsTheMap) {
  HybridLio lio(run_->gt.poses.front(), settings(LioMode::kLoam));
  const LioFrameResult e = lio.process(PointCloud{}, run_->stamps[0]);
  EXPECT_EQ(e.mode, LioFrameMode::kSkipped);
  EXPECT_EQ(e.status, Status::kInsufficientData);
  EXPECT_FALSE(lio.initialized());
  EXPECT_EQ(lio.process(run_->frames[1], run_->stamps[1]).mode, LioFrameMode::kInit);
  EXPECT_TRUE(lio.initialized());
  EXPECT_EQ(lio.process(run_->frames[2], run_->stamps[2]).mode, LioFrameMode::kLoam);
}

TEST_F(HybridLioSiteTest, BadStampsAndSamplesAreRejectedNotFatal) {
  HybridLio lio(run_->gt.poses.front(), settings(LioMode::kLoamImu));
  std::size_t k = 0;
  auto feed = [&](double until) {
    while (k < run_->imu.size() && run_->imu[k].stamp <= until) lio.add_imu(run_->imu[k++]);
  };
  feed(run_->stamps[2] + 0.12);
  // IMU samples out of order, repeated or not finite: dropped and counted.
  ImuSample old = run_->imu[0];
  EXPECT_EQ(lio.add_imu(old), Status::kInvalidInput);
  ImuSample nan = run_->imu[k];
  nan.gyro.x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(lio.add_imu(nan), Status::kInvalidInput);
  EXPECT_EQ(lio.num_imu_dropped(), 2u);

  EXPECT_EQ(lio.process(run_->frames[0], run_->stamps[0]).mode, LioFrameMode::kInit);
  const LioFrameResult a = lio.process(run_->frames[1], run_->stamps[1]);
  EXPECT_EQ(a.mode, LioFrameMode::kLoam);
  // Stamp going backwards, repeated, or NaN: skipped, state unchanged.
  for (double bad : {run_->stamps[0], run_->stamps[1], std::numeric_limits<double>::quiet_NaN()}) {
    const LioFrameResult b = lio.process(run_->frames[2], bad);
    EXPECT_EQ(b.mode, LioFrameMode::kSkipped);
    EXPECT_EQ(b.status, Status::kInvalidInput);
    EXPECT_TRUE(b.T_world_base.isApprox(a.T_world_base));
  }
  EXPECT_EQ(lio.num_frames(), 2u);
  // An empty frame: prediction only (the IMU carries the state), then the LiDAR again.
  const LioFrameResult e = lio.process(PointCloud{}, run_->stamps[2]);
  EXPECT_EQ(e.mode, LioFrameMode::kPrediction);
  EXPECT_EQ(e.status, Status::kInsufficientData);
  EXPECT_TRUE(e.imu_used);
  feed(run_->stamps[3] + 0.12);
  // A frame without per-point times and rings (rows from the elevation angles).
  PointCloud bare;
  bare.points = run_->frames[3].points;
  const LioFrameResult f = lio.process(bare, run_->stamps[3]);
  EXPECT_EQ(f.mode, LioFrameMode::kLoam);
  EXPECT_FALSE(f.deskewed);
  EXPECT_LT(position_error(f, 3), 0.05);
  // A cloud with inconsistent fields is misuse.
  PointCloud broken = run_->frames[4];
  broken.times.pop_back();
  EXPECT_THROW(lio.process(broken, run_->stamps[4]), Error);
}

TEST(HybridLioTest, LeavingTheHouseTheGroundPlaneKeepsFramesMoving) {
  // Seed 1's site route starts its excursion: 15 m straight away from FZK-Haus, the house soon
  // 15..30 m behind, the road all around. With the pair test alone, the road returns it misses
  // stay among the structure and hold the frames back. Measured (Release): LiDAR only
  // 0.024 m end error with the ground plane, 0.080 m with the pair test alone; hybrid 0.044 m and
  // 0.031 m (over the whole site route the plane matters far more).
  PLUMB_REQUIRE_DATA(ifc, "ifc/buildings/AC20-FZK-Haus.ifc");
  const std::string dir = test::temp_path("hybrid_lio_open_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  sim::ScenarioSettings ss = sim::scenario_defaults(sim::ScenarioKind::kSite);
  ss.length = 15.0;
  ss.seed = 1;
  simulate_to_dump(bim::build_mesh(bim::read_ifc(ifc)), dir, ss);
  const io::FrameDumpReader dump(dir);
  const Trajectory gt = dump.ground_truth();
  const std::vector<ImuSample> imu = dump.imu();
  auto end_error = [&](LioMode mode, double ground_plane_tolerance) {
    HybridLioSettings s;
    s.mode = mode;
    s.features.ground_plane_tolerance = ground_plane_tolerance;
    s.T_base_lidar = dump.meta().T_base_lidar;
    s.T_base_imu = dump.meta().T_base_imu;
    HybridLio lio(gt.poses.front(), s);
    std::size_t k = 0;
    LioFrameResult r;
    for (std::size_t i = 0; i < dump.num_frames(); ++i) {
      while (k < imu.size() && imu[k].stamp <= dump.stamp(i) + 0.12) lio.add_imu(imu[k++]);
      r = lio.process(dump.frame(i), dump.stamp(i));
    }
    return (r.T_world_base.translation() - gt.poses.back().translation()).norm();
  };
  const double plane = HybridLioSettings{}.features.ground_plane_tolerance;
  const double loam = end_error(LioMode::kLoam, plane), loam_pairs = end_error(LioMode::kLoam, 0.0);
  const double hybrid = end_error(LioMode::kHybrid, plane);
  std::filesystem::remove_all(dir);
  EXPECT_LT(loam, 0.2);
  EXPECT_LT(hybrid, 0.2);
  EXPECT_LT(loam, 0.5 * loam_pairs);
}

TEST(HybridLioTest, FramesWithoutFeaturesFallBackToPrediction) {
  // LiDAR only, nothing but a few scattered points: never a crash, the constant-velocity prediction.
  HybridLioSettings s;
  s.mode = LioMode::kLoam;
  HybridLio lio(Eigen::Isometry3d::Identity(), s);
  PointCloud sparse;
  sparse.points = {Vector3f(1, 2, 0), Vector3f(5, -3, 1), Vector3f(-4, 0.5f, 0.2f)};
  EXPECT_EQ(lio.process(sparse, 0.0).mode, LioFrameMode::kInit);
  for (int i = 1; i < 4; ++i) {
    const LioFrameResult r = lio.process(sparse, 0.1 * i);
    EXPECT_EQ(r.mode, LioFrameMode::kPrediction);
    EXPECT_EQ(r.status, Status::kInsufficientData);
    EXPECT_TRUE(r.T_world_base.matrix().allFinite());
  }
  // IMU modes without any IMU sample: every interval is a gap, the LiDAR-only fallback.
  s.mode = LioMode::kHybrid;
  HybridLio lio2(Eigen::Isometry3d::Identity(), s);
  lio2.process(sparse, 0.0);
  const LioFrameResult r = lio2.process(sparse, 0.1);
  EXPECT_TRUE(r.imu_gap);
  EXPECT_FALSE(r.imu_used);
  EXPECT_EQ(r.mode, LioFrameMode::kPrediction);
}

TEST(HybridLioTest, BadSettingsAndNamesThrow) {
  HybridLioSettings s;
  s.solver.max_iterations = 0;
  EXPECT_THROW(HybridLio(Eigen::Isometry3d::Identity(), s), Error);
  s = {};
  s.solver.map_neighbors = 2;
  EXPECT_THROW(HybridLio(Eigen::Isometry3d::Identity(), s), Error);
  s = {};
  s.motion.twist_frames = 0;
  EXPECT_THROW(HybridLio(Eigen::Isometry3d::Identity(), s), Error);
  s = {};
  s.solver.map_plane_tolerance = 0.0;
  EXPECT_THROW(HybridLio(Eigen::Isometry3d::Identity(), s), Error);
  s.solver.map_plane_tolerance = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(HybridLio(Eigen::Isometry3d::Identity(), s), Error);
  s = {};
  s.solver.map_plane_ratio = 0.5;
  EXPECT_THROW(HybridLio(Eigen::Isometry3d::Identity(), s), Error);
  s = {};
  s.solver.plane_sigma = 0.0;
  EXPECT_THROW(HybridLio(Eigen::Isometry3d::Identity(), s), Error);
  s = {};
  s.map.plane_map.voxel_size = -1.0;
  EXPECT_THROW(HybridLio(Eigen::Isometry3d::Identity(), s), Error);
  s = {};
  s.solver.icp_neighbors = 2;
  EXPECT_THROW(HybridLio(Eigen::Isometry3d::Identity(), s), Error);
  s.solver.icp_neighbors = 65;
  EXPECT_THROW(HybridLio(Eigen::Isometry3d::Identity(), s), Error);
  s = {};
  s.features.ground_plane_tolerance = -0.1;
  EXPECT_THROW(HybridLio(Eigen::Isometry3d::Identity(), s), Error);
  s.features.ground_plane_tolerance = std::numeric_limits<double>::infinity();
  EXPECT_THROW(HybridLio(Eigen::Isometry3d::Identity(), s), Error);
  s.features.ground_plane_tolerance = 0.0;  // off is allowed
  EXPECT_NO_THROW(HybridLio(Eigen::Isometry3d::Identity(), s));
  Eigen::Isometry3d bad = Eigen::Isometry3d::Identity();
  bad(0, 3) = std::numeric_limits<double>::infinity();
  EXPECT_THROW(HybridLio(bad, HybridLioSettings{}), Error);
  EXPECT_THROW(lio_mode_from_string("lego"), Error);
  EXPECT_EQ(lio_mode_from_string("loam-imu"), LioMode::kLoamImu);
  EXPECT_STREQ(to_string(lio_mode_from_string("hybrid")), "hybrid");
  EXPECT_STREQ(to_string(LioFrameMode::kIcp), "icp");
  EXPECT_THROW(icp_metric_from_string("point-to-line"), Error);
  for (IcpMetric m : {IcpMetric::kPointToPoint, IcpMetric::kPointToDistribution}) {
    EXPECT_EQ(icp_metric_from_string(to_string(m)), m);
  }
}

}  // namespace
}  // namespace plumb
