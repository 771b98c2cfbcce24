// SPDX-License-Identifier: BSD-3-Clause
// run_bim_odometry when the first frame alone fits several places of the building: the run drives on
// with its front end, localizes the first frame from the frames seen on the way, and its trajectory
// still starts at frame 0. Simulated demo office runs cut to start where one frame is not enough.
#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include <unistd.h>

#include <gtest/gtest.h>

#include "plumb/app/run.hpp"
#include "plumb/app/simulate.hpp"
#include "plumb/bim/bim_cloud.hpp"
#include "plumb/bim/ifc.hpp"
#include "plumb/bim/mesh.hpp"
#include "plumb/core/error.hpp"
#include "plumb/io/frame_dump.hpp"
#include "plumb/pipeline/bim_localizer.hpp"
#include "plumb/sim/scenario.hpp"
#include "test_data.hpp"

namespace {

// Sanitizer builds run about ten times slower: they simulate a shorter run, enough for the other
// building's test; the cut start needs the whole run (release builds).
#if defined(__SANITIZE_ADDRESS__)
constexpr double kRunLength = 8.0;
#else
constexpr double kRunLength = 22.0;
#endif

/// The part of `from` that starts at frame `first`: its frames, their wheel odometry and ground truth.
void write_dump_from(const plumb::io::FrameDumpReader& from, std::size_t first, const std::string& dir) {
  std::filesystem::remove_all(dir);
  plumb::io::FrameDumpWriter out(dir, from.meta());
  const double t0 = from.stamp(first);
  for (std::size_t i = first; i < from.num_frames(); ++i) out.add_frame(from.stamp(i), from.frame(i));
  std::vector<plumb::OdomSample> odom;
  for (const plumb::OdomSample& o : from.odometry())
    if (o.stamp >= t0 - 0.1) odom.push_back(o);
  out.write_odometry(odom);
  const plumb::Trajectory gt = from.ground_truth();
  plumb::Trajectory cut;
  for (std::size_t i = first; i < gt.size(); ++i) cut.push_back(gt.stamps[i], gt.poses[i]);
  out.write_ground_truth(cut);
  out.close();
}

class BimOdometryStartTest : public ::testing::Test {
 protected:
  // A demo office run; then, of its frames 10 apart, the first that the localizer cannot place
  // alone (look-alike rooms), and the run cut to start there.
  static void SetUpTestSuite() {
    office_ = new plumb::bim::BimMesh(
        plumb::bim::build_mesh(plumb::bim::read_ifc(plumb::test::source_dir() + "/examples/data/demo_office.ifc")));
    const std::string tag = std::to_string(::getpid());
    whole_ = plumb::test::temp_path("start_whole_" + tag);
    cut_ = plumb::test::temp_path("start_cut_" + tag);
    std::filesystem::remove_all(whole_);
    plumb::sim::ScenarioSettings s = plumb::sim::scenario_defaults(plumb::sim::ScenarioKind::kIndoor);
    s.length = kRunLength;
    s.seed = 3;
    plumb::simulate_to_dump(*office_, whole_, s);
    const plumb::io::FrameDumpReader dump(whole_);
    const plumb::BimLocalizer localizer(*office_, plumb::bim::sample_bim_cloud(*office_, 0.05));
    for (std::size_t i = 0; kRunLength > 20.0 && i + 200 < dump.num_frames(); i += 10) {
      if (localizer.localize(dump.frame(i), dump.meta().T_base_lidar).status != plumb::Status::kOk) {
        first_ = i;
        break;
      }
    }
    if (first_ > 0) write_dump_from(dump, first_, cut_);
  }
  static void TearDownTestSuite() {
    std::filesystem::remove_all(whole_);
    std::filesystem::remove_all(cut_);
    delete office_;
    office_ = nullptr;
  }
  static plumb::bim::BimMesh* office_;
  static std::string whole_, cut_;
  static std::size_t first_;
};
plumb::bim::BimMesh* BimOdometryStartTest::office_ = nullptr;
std::string BimOdometryStartTest::whole_;
std::string BimOdometryStartTest::cut_;
std::size_t BimOdometryStartTest::first_ = 0;

double start_xy_error(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return (a.translation() - b.translation()).head<2>().norm();
}

TEST_F(BimOdometryStartTest, AStartOneFrameCannotPlaceIsFoundByDrivingOn) {
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "needs the 22 m run: release builds";
#endif
  ASSERT_GT(first_, 0u) << "every frame of the run localizes alone: the test lost its case";
  const plumb::io::FrameDumpReader dump(cut_);
  const plumb::Trajectory gt = dump.ground_truth();
  plumb::RunSettings settings;
  const plumb::RunReport r = plumb::run_bim_odometry(dump, *office_, settings);
  ASSERT_EQ(r.localization_status, plumb::Status::kOk);
  EXPECT_GT(r.localization.views, 1u);
  EXPECT_GT(r.localization_frames, 1u);
  EXPECT_LE(r.localization_distance, 10.0);
  EXPECT_LT(r.initial_error_xy, 0.15);
  EXPECT_LT(r.initial_error_yaw_deg, 1.0);
  // The trajectory starts at frame 0 (the frames driven while localizing are back-filled).
  ASSERT_EQ(r.bim.size(), dump.num_frames());
  EXPECT_LT(start_xy_error(r.bim.poses.front(), gt.poses.front()), 0.15);
  EXPECT_LT(r.max_error_bim, 0.15);

  // The first frame alone does not decide: without driving on, the run is not localized.
  settings.start_search_distance = 0.0;
  const plumb::RunReport alone = plumb::run_bim_odometry(dump, *office_, settings);
  EXPECT_NE(alone.localization_status, plumb::Status::kOk);
  EXPECT_EQ(alone.localization_frames, 1u);
  EXPECT_TRUE(alone.bim.empty());
}

// Frames from the demo office driven through a building they were not recorded in: never accepted,
// however far the run drives (a wrong start would be corrected nowhere).
TEST_F(BimOdometryStartTest, ADriveFromAnotherBuildingIsNeverAccepted) {
  PLUMB_REQUIRE_DATA(path, "ifc/buildings/AC20-FZK-Haus.ifc");
  const plumb::bim::BimMesh house = plumb::bim::build_mesh(plumb::bim::read_ifc(path));
  const plumb::io::FrameDumpReader dump(whole_);
  plumb::RunSettings settings;
  settings.start_search_distance = 20.0;
  const plumb::RunReport r = plumb::run_bim_odometry(dump, house, settings);
  EXPECT_NE(r.localization_status, plumb::Status::kOk);
  EXPECT_GT(r.localization.views, static_cast<std::size_t>(kRunLength / 2.0));  // it drove on and tried
  EXPECT_TRUE(r.bim.empty());
}

TEST_F(BimOdometryStartTest, BadStartSearchSettingsAreRefused) {
  const plumb::io::FrameDumpReader dump(whole_);
  plumb::RunSettings settings;
  settings.max_frames = 2;
  settings.start_view_spacing = 0.0;
  EXPECT_THROW(plumb::run_bim_odometry(dump, *office_, settings), plumb::Error);
  settings.start_view_spacing = 1.0;
  settings.start_search_distance = -1.0;
  EXPECT_THROW(plumb::run_bim_odometry(dump, *office_, settings), plumb::Error);
  settings.start_search_distance = std::nan("");
  EXPECT_THROW(plumb::run_bim_odometry(dump, *office_, settings), plumb::Error);
}

}  // namespace
