// SPDX-License-Identifier: BSD-3-Clause
// Trajectories that would give error numbers that look valid but are not: the library must refuse
// them (association, alignment, statistics) and the readers must name the file and line.

#include <cmath>
#include <filesystem>
#include <limits>
#include <string>

#include <gtest/gtest.h>

#include "plumb/core/error.hpp"
#include "plumb/core/lie.hpp"
#include "plumb/eval/align.hpp"
#include "plumb/eval/metrics.hpp"
#include "plumb/io/trajectory.hpp"
#include "test_data.hpp"
#include "test_util.hpp"

namespace plumb::eval {
namespace {

bool contains(const std::string& text, const std::string& what) { return text.find(what) != std::string::npos; }

TEST(EvalBadInputTest, StampsInMillisecondsAgainstSecondsAreRefusedWithBothCounts) {
  const std::string message = test::error_of([] { associate(test::circle_trajectory(747, 1000.0), test::circle_trajectory(747)); });
  EXPECT_TRUE(contains(message, "only 0 pose pairs")) << message;
  EXPECT_TRUE(contains(message, "the 747 poses")) << message;
  EXPECT_TRUE(contains(message, "same clock")) << message;
}

TEST(EvalBadInputTest, TooFewPairsAbsoluteAndAsAShare) {
  // 40 of 200 overlap in time: below the default half, accepted when the share is relaxed.
  Trajectory late = test::circle_trajectory(200);
  for (double& s : late.stamps) s += 16.0;
  EXPECT_TRUE(contains(test::error_of([&] { associate(late, test::circle_trajectory(200)); }), "only 40 pose pairs"));
  AssociationSettings relaxed;
  relaxed.min_pair_fraction = 0.1;
  EXPECT_EQ(associate(late, test::circle_trajectory(200), relaxed).estimate.size(), 40u);
  // Two poses are below the absolute minimum whatever the share; by index as well.
  EXPECT_TRUE(contains(test::error_of([] { associate(test::circle_trajectory(2), test::circle_trajectory(2)); }), "only 2 pose pairs"));
  Trajectory no_stamps = test::circle_trajectory(2);
  no_stamps.stamps.clear();
  EXPECT_TRUE(contains(test::error_of([&] { associate(no_stamps, no_stamps); }), "paired by index"));
  relaxed.min_pairs = 2;
  EXPECT_EQ(associate(test::circle_trajectory(2), test::circle_trajectory(2), relaxed).estimate.size(), 2u);
  AssociationSettings nan_settings;
  nan_settings.max_time_difference = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(associate(test::circle_trajectory(10), test::circle_trajectory(10), nan_settings), Error);
}

TEST(EvalBadInputTest, StampsThatDoNotIncreaseAreRefused) {
  Trajectory unordered = test::circle_trajectory(50);
  std::swap(unordered.stamps[10], unordered.stamps[30]);
  const std::string message = test::error_of([&] { associate(unordered, test::circle_trajectory(50)); });
  EXPECT_TRUE(contains(message, "estimate stamps do not strictly increase: pose 11")) << message;
  Trajectory repeated = test::circle_trajectory(50);
  repeated.stamps[20] = repeated.stamps[19];
  EXPECT_TRUE(contains(test::error_of([&] { associate(test::circle_trajectory(50), repeated); }), "reference stamps")) << message;
}

TEST(EvalBadInputTest, NonFinitePosesAndErrorsAreRefused) {
  Trajectory bad = test::circle_trajectory(20);
  bad.poses[5].translation().x() = std::numeric_limits<double>::infinity();
  EXPECT_TRUE(contains(test::error_of([&] { associate(bad, test::circle_trajectory(20)); }), "estimate pose 5 is not finite"));
  EXPECT_THROW(compute_stats({1.0, std::numeric_limits<double>::infinity()}), Error);
  EXPECT_THROW(compute_stats({1.0, std::numeric_limits<double>::quiet_NaN()}), Error);
  std::vector<Vector3d> points = {Vector3d(0, 0, 0), Vector3d(1, 0, 0), Vector3d(0, 1, 0)};
  std::vector<Vector3d> huge = points;
  huge[1].x() = 1e308;
  huge[2].x() = 1e308;
  EXPECT_THROW(umeyama(huge, points, false), Error);
}

TEST(EvalBadInputTest, CollinearOrTooFewPositionsGiveADegenerateAlignmentStatus) {
  Trajectory line;
  for (int i = 0; i < 5; ++i) line.push_back(0.1 * i, se3::make(Matrix3d::Identity(), Vector3d(i, 2 * i, 0)));
  for (AlignMode mode : {AlignMode::kSE3, AlignMode::kSim3}) {
    ApeSettings settings;
    settings.align = mode;
    EXPECT_EQ(compute_ape(line, line, settings).status, Status::kDegenerate) << to_string(mode);
  }
  const Trajectory two = test::circle_trajectory(2);
  EXPECT_EQ(compute_ape(two, two).status, Status::kDegenerate);
  const Trajectory one = test::circle_trajectory(1);
  EXPECT_EQ(compute_ape(one, one).status, Status::kInsufficientData);
  EXPECT_EQ(compute_ape(test::circle_trajectory(20), test::circle_trajectory(20)).status, Status::kOk);
}

// ---- the trajectory readers -------------------------------------------------------------------

TEST(EvalBadInputTest, TumReaderNamesLineOfAStampThatDoesNotIncrease) {
  const std::string text = "# t x y z qx qy qz qw\n1 0 0 0 0 0 0 1\n2 0 0 0 0 0 0 1\n1.5 0 0 0 0 0 0 1\n";
  const std::string message = test::error_of([&] { io::parse_tum(text, "est.tum"); });
  EXPECT_TRUE(contains(message, "est.tum:4: stamp 1.5 is earlier than the stamp of line 3")) << message;
  EXPECT_TRUE(contains(test::error_of([] { io::parse_tum("1 0 0 0 0 0 0 1\n1 0 0 0 0 0 0 1\n", "a.tum"); }),
                       "a.tum:2: stamp 1 repeats"));
  io::TrajectoryReadSettings any_order;
  any_order.require_increasing_stamps = false;
  EXPECT_EQ(io::parse_tum(text, "est.tum", any_order).size(), 3u);
}

TEST(EvalBadInputTest, ReadersRefuseAbsurdCoordinatesNamingTheLine) {
  const std::string tum = "1 0 0 0 0 0 0 1\n2 1e300 0 0 0 0 0 1\n";
  EXPECT_TRUE(contains(test::error_of([&] { io::parse_tum(tum, "huge.tum"); }), "huge.tum:2: position"));
  const std::string kitti = "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 0 0 0 1 -2e9\n";
  EXPECT_TRUE(contains(test::error_of([&] { io::parse_kitti(kitti, "huge.txt"); }), "huge.txt:2: position"));
  // UTM-sized coordinates are fine.
  EXPECT_EQ(io::parse_tum("1 500000 5400000 300 0 0 0 1\n", "utm.tum").size(), 1u);
}

TEST(EvalBadInputTest, TimesReaderNamesLineOfAStampThatDoesNotIncrease) {
  EXPECT_TRUE(contains(test::error_of([] { io::parse_times("0\n0.1\n0.3\n0.2\n", "times.txt"); }), "times.txt:4:"));
}

TEST(EvalBadInputTest, ReadersSayADirectoryIsADirectory) {
  const std::string dir = test::temp_path("eval_bad_input_dir");
  std::filesystem::create_directories(dir);
  EXPECT_TRUE(contains(test::error_of([&] { io::read_tum(dir); }), dir + ": is a directory"));
  EXPECT_TRUE(contains(test::error_of([&] { io::read_kitti(dir); }), dir + ": is a directory"));
  EXPECT_TRUE(contains(test::error_of([&] { io::read_times(dir); }), dir + ": is a directory"));
  EXPECT_TRUE(contains(test::error_of([&] { io::read_tum(dir + "/missing.tum"); }), "missing.tum: no such file"));
}

}  // namespace
}  // namespace plumb::eval
