// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/eval/metrics.hpp"

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <string>

#include <gtest/gtest.h>

#include "plumb/core/error.hpp"
#include "plumb/core/lie.hpp"
#include "plumb/eval/kitti_segments.hpp"
#include "plumb/io/trajectory.hpp"
#include "test_data.hpp"

namespace plumb::eval {
namespace {


// The number after "key": in a flat JSON object (evo's stats.json); NaN when absent.
double json_number(const std::string& text, const std::string& key) {
  const std::size_t k = text.find("\"" + key + "\"");
  if (k == std::string::npos) return std::numeric_limits<double>::quiet_NaN();
  const std::size_t colon = text.find(':', k);
  return std::strtod(text.c_str() + colon + 1, nullptr);
}

std::string read_text(const std::string& path) {
  std::ifstream in(path);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// A planar figure-of-eight-ish path, stamps 0.1 s apart.
Trajectory curved_path(std::size_t n) {
  Trajectory t;
  for (std::size_t i = 0; i < n; ++i) {
    const double a = 0.05 * static_cast<double>(i);
    t.push_back(0.1 * static_cast<double>(i),
                se3::make(so3::exp(Vector3d(0, 0.1 * std::sin(a), a)),
                          Vector3d(20 * std::sin(a), 10 * std::sin(2 * a), 0.5 * std::cos(a))));
  }
  return t;
}

Trajectory straight_line(std::size_t n, double step) {
  Trajectory t;
  for (std::size_t i = 0; i < n; ++i) {
    t.push_back(static_cast<double>(i), se3::make(Matrix3d::Identity(), Vector3d(step * static_cast<double>(i), 0, 0)));
  }
  return t;
}

void expect_stats_near(const ErrorStats& s, const std::string& json, double tol) {
  EXPECT_NEAR(s.rmse, json_number(json, "rmse"), tol);
  EXPECT_NEAR(s.mean, json_number(json, "mean"), tol);
  EXPECT_NEAR(s.median, json_number(json, "median"), tol);
  EXPECT_NEAR(s.std, json_number(json, "std"), tol);
  EXPECT_NEAR(s.min, json_number(json, "min"), tol);
  EXPECT_NEAR(s.max, json_number(json, "max"), tol);
  EXPECT_NEAR(s.sse, json_number(json, "sse"), tol * json_number(json, "sse"));  // relative
}

TEST(ErrorStatsTest, MatchesNumpyDefinitions) {
  // numpy: rmse sqrt(30/4), mean 2.5, median 2.5, std (ddof 0) sqrt(1.25), sse 30.
  const ErrorStats s = compute_stats({4.0, 1.0, 3.0, 2.0});
  EXPECT_DOUBLE_EQ(s.rmse, std::sqrt(7.5));
  EXPECT_DOUBLE_EQ(s.mean, 2.5);
  EXPECT_DOUBLE_EQ(s.median, 2.5);
  EXPECT_DOUBLE_EQ(s.std, std::sqrt(1.25));
  EXPECT_EQ(s.min, 1.0);
  EXPECT_EQ(s.max, 4.0);
  EXPECT_EQ(s.sse, 30.0);
  EXPECT_EQ(s.count, 4u);
  EXPECT_EQ(compute_stats({5.0, 1.0, 9.0}).median, 5.0);
  EXPECT_EQ(compute_stats({7.0}).std, 0.0);
  EXPECT_THROW(compute_stats({}), Error);
  EXPECT_THROW(compute_stats({1.0, std::numeric_limits<double>::quiet_NaN()}), Error);
}

TEST(ApeTest, IdenticalTrajectoriesHaveZeroError) {
  const Trajectory t = curved_path(300);
  for (AlignMode mode : {AlignMode::kNone, AlignMode::kSE3, AlignMode::kSim3}) {
    ApeSettings settings;
    settings.align = mode;
    const ApeResult ape = compute_ape(t, t, settings);
    EXPECT_LT(ape.translation.stats.max, 1e-12);
    EXPECT_LT(ape.rotation_deg.stats.max, 1e-6);
    EXPECT_LT(ape.full.stats.max, 1e-12);
    EXPECT_EQ(ape.translation.values.size(), t.size());
  }
  RpeSettings rpe_settings;
  rpe_settings.delta = 5;
  const RpeResult rpe = compute_rpe(t, t, rpe_settings);
  EXPECT_EQ(rpe.status, Status::kOk);
  EXPECT_EQ(rpe.translation.stats.max, 0.0);
  EXPECT_LT(rpe.rotation_deg.stats.max, 1e-6);
}

TEST(ApeTest, KnownOffsetsGiveKnownErrors) {
  // Estimate = reference with the body rotated by 2 deg about its own x axis and shifted 0.25 m
  // along world y: without alignment APE translation = 0.25, rotation = 2 deg for every pose.
  const Trajectory ref = curved_path(200);
  Trajectory est = ref;
  const double angle = 2.0 * kPi / 180.0;
  for (auto& P : est.poses) {
    P = P * se3::make(so3::exp(Vector3d(angle, 0, 0)), Vector3d::Zero());
    P.translation() += Vector3d(0, 0.25, 0);
  }
  ApeSettings none;
  none.align = AlignMode::kNone;
  const ApeResult ape = compute_ape(est, ref, none);
  EXPECT_NEAR(ape.translation.stats.min, 0.25, 1e-12);
  EXPECT_NEAR(ape.translation.stats.max, 0.25, 1e-12);
  EXPECT_NEAR(ape.rotation_deg.stats.min, 2.0, 1e-9);
  EXPECT_NEAR(ape.rotation_deg.stats.max, 2.0, 1e-9);
  // SE(3) alignment removes the shift (the rotation offset is in the body frame and stays).
  const ApeResult aligned = compute_ape(est, ref);
  EXPECT_LT(aligned.translation.stats.max, 1e-10);
  EXPECT_NEAR(aligned.rotation_deg.stats.mean, 2.0, 1e-9);
  EXPECT_THROW(compute_ape(est, curved_path(10)), Error);
}

TEST(ApeTest, HorizontalAxesLeaveHeightOut) {
  // Pose i is off by (3, 4) * (i + 1) in x, y and by 12 in z: horizontal errors 5, 10, 15, 20.
  const Trajectory ref = straight_line(4, 1.0);
  Trajectory est = ref;
  for (std::size_t i = 0; i < est.size(); ++i) {
    est.poses[i].translation() += Vector3d(3.0, 4.0, 0.0) * static_cast<double>(i + 1) + Vector3d(0, 0, 12.0);
  }
  ApeSettings xy;
  xy.align = AlignMode::kNone;
  xy.axes = PositionAxes::kXY;
  const ApeResult ape = compute_ape(est, ref, xy);
  EXPECT_EQ(ape.translation.values, (std::vector<double>{5, 10, 15, 20}));
  EXPECT_EQ(ape.translation.stats.max, 20.0);
  EXPECT_EQ(ape.translation.stats.min, 5.0);
  EXPECT_DOUBLE_EQ(ape.translation.stats.rmse, std::sqrt((25.0 + 100.0 + 225.0 + 400.0) / 4.0));
  EXPECT_EQ(ape.rotation_deg.stats.max, 0.0);  // the axes concern positions only
  // The default measures all three: the first pose is 13 m off (5-12-13).
  ApeSettings xyz;
  xyz.align = AlignMode::kNone;
  const ApeResult full = compute_ape(est, ref, xyz);
  EXPECT_DOUBLE_EQ(full.translation.values.front(), 13.0);
  EXPECT_DOUBLE_EQ(full.translation.stats.max, std::hypot(20.0, 12.0));
}

TEST(RpeTest, FramePairsAreConsecutiveAndScaleErrorIsLinear) {
  const Trajectory ref = straight_line(101, 1.0);
  const Trajectory est = straight_line(101, 0.9);  // 10 % short
  const auto pairs = rpe_pairs(ref, 7, DeltaUnit::kFrames);
  ASSERT_EQ(pairs.size(), 14u);  // (0,7) ... (91,98), as numpy arange(0, 101, 7)
  EXPECT_EQ(pairs.front(), std::make_pair(std::size_t{0}, std::size_t{7}));
  EXPECT_EQ(pairs.back(), std::make_pair(std::size_t{91}, std::size_t{98}));
  RpeSettings settings;
  settings.delta = 5;
  const RpeResult rpe = compute_rpe(est, ref, settings);
  EXPECT_NEAR(rpe.translation.stats.min, 0.5, 1e-12);
  EXPECT_NEAR(rpe.translation.stats.max, 0.5, 1e-12);
  EXPECT_EQ(rpe.rotation_deg.stats.max, 0.0);
  settings.delta = 2.5;
  EXPECT_THROW(compute_rpe(est, ref, settings), Error);
  settings.delta = 0;
  EXPECT_THROW(compute_rpe(est, ref, settings), Error);
}

TEST(RpeTest, MetrePairsFollowEvoConsecutiveRule) {
  const Trajectory ref = straight_line(101, 1.0);
  const Trajectory est = straight_line(101, 0.9);
  // Along the reference: 10 m reached at index 10 (index 0 is not a mark), then every 10 poses.
  const auto along_ref = rpe_pairs(ref, 10.0, DeltaUnit::kMeters);
  ASSERT_EQ(along_ref.size(), 9u);
  EXPECT_EQ(along_ref.front(), std::make_pair(std::size_t{10}, std::size_t{20}));
  // Along the estimate (0.9 m steps): 11 steps = 9.9 m < 10, so marks every 12 poses.
  const auto along_est = rpe_pairs(est, 10.0, DeltaUnit::kMeters);
  ASSERT_EQ(along_est.size(), 7u);
  EXPECT_EQ(along_est.front(), std::make_pair(std::size_t{12}, std::size_t{24}));
  RpeSettings settings;
  settings.delta = 10;
  settings.unit = DeltaUnit::kMeters;
  const RpeResult rpe_est = compute_rpe(est, ref, settings);
  EXPECT_NEAR(rpe_est.translation.stats.mean, 1.2, 1e-9);
  settings.pairs_along = PathSource::kReference;
  EXPECT_NEAR(compute_rpe(est, ref, settings).translation.stats.mean, 1.0, 1e-9);
  settings.delta = 1000;  // longer than the path
  EXPECT_EQ(compute_rpe(est, ref, settings).status, Status::kInsufficientData);
}

TEST(AssociateTest, NearestStampWithinMaxDifference) {
  Trajectory ref, est;
  for (int i = 0; i < 100; ++i) ref.push_back(0.1 * i, se3::make(Matrix3d::Identity(), Vector3d(i, 0, 0)));
  // Every third reference pose, stamped 3 ms late, plus one stamp far from any reference.
  for (int i = 0; i < 100; i += 3) est.push_back(0.1 * i + 0.003, se3::make(Matrix3d::Identity(), Vector3d(i, 1, 0)));
  est.push_back(50.0, Eigen::Isometry3d::Identity());
  const AssociationResult a = associate(est, ref);
  EXPECT_TRUE(a.by_stamp);
  ASSERT_EQ(a.estimate.size(), 34u);
  for (std::size_t k = 0; k < a.estimate.size(); ++k) {
    EXPECT_EQ(a.reference_indices[k], 3 * k);
    EXPECT_EQ(a.estimate_indices[k], k);
    EXPECT_EQ(a.estimate.poses[k].translation().x(), a.reference.poses[k].translation().x());
  }
  // A 2 ms tolerance rejects all; an offset of -3 ms brings them back.
  AssociationSettings tight;
  tight.max_time_difference = 0.002;
  EXPECT_THROW(associate(est, ref, tight), Error);
  tight.time_offset = -0.003;
  EXPECT_EQ(associate(est, ref, tight).estimate.size(), 34u);
}

TEST(AssociateTest, ByIndexWithoutStamps) {
  Trajectory ref = straight_line(10, 1.0);
  Trajectory est = straight_line(10, 1.1);
  est.stamps.clear();
  const AssociationResult a = associate(est, ref);
  EXPECT_FALSE(a.by_stamp);
  EXPECT_EQ(a.estimate.size(), 10u);
  EXPECT_EQ(a.estimate.stamps, ref.stamps);  // borrowed from the reference
  EXPECT_THROW(associate(straight_line(9, 1.0), Trajectory{est.stamps, est.poses}, {}), Error);
  Trajectory short_est = est;
  short_est.poses.pop_back();
  EXPECT_THROW(associate(short_est, ref), Error);
}

TEST(DriftTest, ConstantDriftRateGivesThatPercentage) {
  // The estimate wanders off sideways by 0.5 % of the distance travelled along the reference.
  const Trajectory ref = curved_path(400);
  const std::vector<double> s = path_lengths(ref);
  Trajectory est = ref;
  for (std::size_t i = 0; i < est.size(); ++i) est.poses[i].translation() += Vector3d(0, 0, 0.005 * s[i]);
  const auto samples = drift_at(est, ref, {1, 100, 399});
  ASSERT_EQ(samples.size(), 3u);
  for (const DriftSample& d : samples) {
    EXPECT_NEAR(d.drift_pct, 0.5, 1e-10) << d.index;
    EXPECT_EQ(d.path_length, s[d.index]);
  }
  EXPECT_TRUE(std::isnan(drift_at(est, ref, {0})[0].drift_pct));
  EXPECT_THROW(drift_at(est, ref, {400}), Error);
  // Path measured on the estimate: longer than the reference's, so a smaller percentage.
  DriftSettings along_est;
  along_est.path = PathSource::kEstimate;
  EXPECT_LT(drift_at(est, ref, {399}, along_est)[0].drift_pct, 0.5);
}

TEST(DriftTest, PathLengthsAndNearestIndex) {
  const Trajectory line = straight_line(5, 2.0);
  EXPECT_EQ(path_lengths(line), (std::vector<double>{0, 2, 4, 6, 8}));
  EXPECT_EQ(nearest_index(line, 2.4), 2u);
  EXPECT_EQ(nearest_index(line, 2.5), 2u);  // tie -> earlier
  EXPECT_EQ(nearest_index(line, -3), 0u);
  EXPECT_EQ(nearest_index(line, 99), 4u);
  Trajectory no_stamps = line;
  no_stamps.stamps.clear();
  EXPECT_THROW(nearest_index(no_stamps, 1.0), Error);
}

TEST(DriftTest, HorizontalAxesMeasureTheFloorPlanPath) {
  // A ramp rising 12 m per 5 m across the floor: 13 m per step in 3-D, 5 m in the floor plan.
  Trajectory ref;
  for (int i = 0; i < 4; ++i) ref.push_back(i, se3::make(Matrix3d::Identity(), Vector3d(3.0, 4.0, 12.0) * i));
  EXPECT_EQ(path_lengths(ref, PositionAxes::kXY), (std::vector<double>{0, 5, 10, 15}));
  EXPECT_EQ(path_lengths(ref), (std::vector<double>{0, 13, 26, 39}));
  // 0.5 m off across the floor and 2 m in height: 0.5 m over the 10 m of floor travelled at pose 2.
  Trajectory est = ref;
  for (auto& P : est.poses) P.translation() += Vector3d(0.3, 0.4, 2.0);
  DriftSettings xy;
  xy.axes = PositionAxes::kXY;
  const std::vector<DriftSample> d = drift_at(est, ref, {2}, xy);
  ASSERT_EQ(d.size(), 1u);
  EXPECT_NEAR(d[0].error, 0.5, 1e-12);
  EXPECT_EQ(d[0].path_length, 10.0);
  EXPECT_NEAR(d[0].drift_pct, 5.0, 1e-10);
  EXPECT_NEAR(drift_at(est, ref, {2})[0].error, std::sqrt(0.25 + 4.0), 1e-12);
}

TEST(KittiSegmentTest, StraightLineScaleErrorGivesKnownPercentage) {
  // 1 m spacing, estimate 2 % long. The devkit takes the first frame strictly beyond L metres,
  // i.e. L + 1 m away, so each segment's error is 0.02 (L + 1) / L.
  const std::size_t n = 1000;
  const Trajectory ref = straight_line(n, 1.0);
  const Trajectory est = straight_line(n, 1.02);
  const KittiSegmentResult r = compute_kitti_segment_errors(est, ref);
  ASSERT_EQ(r.status, Status::kOk);
  ASSERT_EQ(r.per_length.size(), 8u);
  std::size_t expected_segments = 0;
  double expected_sum = 0.0;
  for (const KittiLengthAverage& a : r.per_length) {
    const std::size_t L = static_cast<std::size_t>(a.length);
    // First frames 0, 10, ... with first + L + 1 <= n - 1.
    const std::size_t count = (n - 2 - L) / 10 + 1;
    EXPECT_EQ(a.num_segments, count) << L;
    EXPECT_NEAR(a.translation_pct, 2.0 * static_cast<double>(L + 1) / static_cast<double>(L), 1e-9) << L;
    EXPECT_EQ(a.rotation_deg_per_m, 0.0);
    expected_segments += count;
    expected_sum += static_cast<double>(count) * 2.0 * static_cast<double>(L + 1) / static_cast<double>(L);
  }
  EXPECT_EQ(r.segments.size(), expected_segments);
  EXPECT_NEAR(r.translation_pct, expected_sum / static_cast<double>(expected_segments), 1e-9);
  EXPECT_EQ(compute_kitti_segment_errors(straight_line(50, 1.0), straight_line(50, 1.0)).status,
            Status::kInsufficientData);
}

TEST(KittiSegmentTest, ConstantYawRateErrorGivesKnownDegPerMetre) {
  // Reference straight; the estimate turns its heading 0.01 deg per metre (positions kept): every
  // segment's rotation error is 0.01 deg/m times (L + 1) / L.
  const std::size_t n = 300;
  const Trajectory ref = straight_line(n, 1.0);
  Trajectory est = ref;
  for (std::size_t i = 0; i < n; ++i) {
    est.poses[i].linear() = so3::exp(Vector3d(0, 0, 0.01 * kPi / 180.0 * static_cast<double>(i)));
  }
  KittiSegmentSettings settings;
  settings.lengths = {100};
  const KittiSegmentResult r = compute_kitti_segment_errors(est, ref, settings);
  ASSERT_EQ(r.status, Status::kOk);
  EXPECT_NEAR(r.rotation_deg_per_m, 0.01 * 101.0 / 100.0, 1e-9);
}

// Golden values: evo's results for ORB-SLAM2 on KITTI 00 (shared/data/.../evo_reference).
class EvoKitti00Test : public ::testing::Test {
 protected:
  void SetUp() override {
    est_path_ = test::data_path("trajectories/kitti00/KITTI_00_ORB.txt");
    ref_path_ = test::data_path("trajectories/kitti00/KITTI_00_gt.txt");
    if (!test::file_exists(est_path_) || !test::file_exists(ref_path_)) {
      GTEST_SKIP() << "test data not found: " << est_path_ << " (set PLUMB_DATA_DIR)";
    }
    io::TrajectoryReadSettings as_printed;  // evo does not re-orthonormalize
    as_printed.orthonormalize = false;
    est_ = io::read_kitti(est_path_, "", as_printed);
    ref_ = io::read_kitti(ref_path_, "", as_printed);
  }
  std::string est_path_, ref_path_;
  Trajectory est_, ref_;
};

// Tolerance: absolute 1e-6 on every statistic (relative for sse); the values agree to ~1e-12.
TEST_F(EvoKitti00Test, ApeSe3TranslationMatchesEvo) {
  const std::string stats = read_text(test::data_path("trajectories/kitti00/evo_reference/orb_ape_stats.json"));
  ASSERT_FALSE(stats.empty());
  const ApeResult ape = compute_ape(est_, ref_);  // SE(3) Umeyama by default
  EXPECT_EQ(ape.translation.stats.count, 4541u);
  expect_stats_near(ape.translation.stats, stats, 1e-6);
  EXPECT_NEAR(ape.translation.stats.rmse, 1.3034497, 1e-7);  // as quoted in the issue
}

TEST_F(EvoKitti00Test, Rpe10MetresTranslationMatchesEvo) {
  const std::string stats = read_text(test::data_path("trajectories/kitti00/evo_reference/orb_rpe_stats.json"));
  ASSERT_FALSE(stats.empty());
  RpeSettings settings;
  settings.delta = 10.0;
  settings.unit = DeltaUnit::kMeters;
  const RpeResult rpe = compute_rpe(est_, ref_, settings);
  ASSERT_EQ(rpe.status, Status::kOk);
  expect_stats_near(rpe.translation.stats, stats, 1e-6);
  EXPECT_NEAR(rpe.translation.stats.rmse, 0.2262613, 1e-7);
  // SE(3) alignment cannot change an RPE.
  settings.align = AlignMode::kSE3;
  expect_stats_near(compute_rpe(est_, ref_, settings).translation.stats, stats, 1e-6);
}

TEST_F(EvoKitti00Test, OrthonormalizedRotationsStayWithinTolerance) {
  const std::string stats = read_text(test::data_path("trajectories/kitti00/evo_reference/orb_rpe_stats.json"));
  const Trajectory est = io::read_kitti(est_path_);  // default: projected onto SO(3)
  const Trajectory ref = io::read_kitti(ref_path_);
  RpeSettings settings;
  settings.delta = 10.0;
  settings.unit = DeltaUnit::kMeters;
  expect_stats_near(compute_rpe(est, ref, settings).translation.stats, stats, 1e-6);
}

TEST_F(EvoKitti00Test, KittiSegmentsMatchOrbSlam2Paper) {
  // Mur-Artal & Tardos, "ORB-SLAM2", IEEE T-RO 2017, Table II (stereo, KITTI 00):
  // t_rel 0.70 %, r_rel 0.25 deg/100 m (rounded to 2 digits).
  const KittiSegmentResult r = compute_kitti_segment_errors(est_, ref_);
  ASSERT_EQ(r.status, Status::kOk);
  EXPECT_NEAR(r.translation_pct, 0.70, 0.005);
  EXPECT_NEAR(r.rotation_deg_per_m * 100.0, 0.25, 0.005);
}

}  // namespace
}  // namespace plumb::eval
