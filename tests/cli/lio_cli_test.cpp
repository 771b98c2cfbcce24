// SPDX-License-Identifier: BSD-3-Clause
// `plumb lio` on a short simulated site run (made here with the sim library), as a user runs it.
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "cli_runner.hpp"
#include "plumb/io/frame_dump.hpp"
#include "plumb/io/trajectory.hpp"
#include "sim_site_run.hpp"
#include "test_data.hpp"

namespace plumb {
namespace {

namespace fs = std::filesystem;
using test::run_cli;
using Json = nlohmann::json;

class LioCliTest : public test::CliTest {
 protected:
  static void SetUpTestSuite() { test::simulate_fzk_site_run("lio_cli_dump", dir_); }
  static void TearDownTestSuite() {
    if (!dir_.empty()) fs::remove_all(dir_);
  }
  void SetUp() override {
    test::CliTest::SetUp();
    PLUMB_REQUIRE_DATA(ifc, "ifc/buildings/AC20-FZK-Haus.ifc");
  }
  /// A copy of the dump without some of its files.
  static std::string copy_without(const std::string& name, const std::vector<std::string>& drop) {
    const std::string out = test::temp_path("lio_cli_" + name + "_" + std::to_string(::getpid()));
    fs::remove_all(out);
    fs::copy(dir_, out, fs::copy_options::recursive);
    for (const std::string& f : drop) fs::remove(out + "/" + f);
    return out;
  }
  static std::string dir_;
};

std::string LioCliTest::dir_;

TEST_F(LioCliTest, HybridWritesTrajectoryAndReport) {
  const std::string out = test::temp_path("lio_cli_out_hybrid_" + std::to_string(::getpid()));
  fs::remove_all(out);
  const test::RunResult r = run_cli("lio '" + dir_ + "' --mode hybrid -o '" + out + "' --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const Json j = Json::parse(r.out);
  const io::FrameDumpReader dump(dir_);
  const std::size_t n = dump.num_frames();
  EXPECT_EQ(j.at("mode"), "hybrid");
  EXPECT_EQ(j.at("frames").get<std::size_t>(), n);
  const Json& m = j.at("frames_per_mode");
  EXPECT_EQ(m.at("init").get<std::size_t>(), 1u);
  EXPECT_EQ(m.at("init").get<std::size_t>() + m.at("loam").get<std::size_t>() + m.at("icp").get<std::size_t>() +
                m.at("prediction").get<std::size_t>() + m.at("skipped").get<std::size_t>(),
            n);
  EXPECT_EQ(j.at("failures").at("imu_gaps").get<std::size_t>(), 0u);
  EXPECT_GT(j.at("timing").at("frames_per_second").get<double>(), 0.0);
  // The report file holds the same JSON.
  std::ifstream in(out + "/report.json");
  EXPECT_EQ(Json::parse(in), j);
  // trajectory.tum: one base pose per frame, starting at gt.tum's first pose, ending near the truth.
  const Trajectory est = io::read_tum(out + "/trajectory.tum");
  const Trajectory gt = dump.ground_truth();
  ASSERT_EQ(est.size(), n);
  EXPECT_NEAR(est.stamps.front(), gt.stamps.front(), 1e-6);
  EXPECT_LT((est.poses.front().translation() - gt.poses.front().translation()).norm(), 1e-6);
  const double end = (est.poses.back().translation() - gt.poses.back().translation()).norm();
  EXPECT_LT(end, 1.0);  // failure bound over the ~3 m driven
  EXPECT_NEAR(j.at("end_error").get<double>(), end, 1e-4);
  EXPECT_NEAR(j.at("path_length").get<double>(), 3.0, 0.5);
  EXPECT_EQ(j.at("map_window").get<std::size_t>(), 0u);

  // --map-window: maps of the last 5 frames only; still a valid run, and the report says so.
  const test::RunResult w = run_cli("lio '" + dir_ + "' --mode hybrid --map-window 5 -o '" + out + "' --json");
  ASSERT_EQ(w.exit_code, 0) << w.err;
  const Json jw = Json::parse(w.out);
  EXPECT_EQ(jw.at("map_window").get<std::size_t>(), 5u);
  EXPECT_EQ(jw.at("frames").get<std::size_t>(), n);
  EXPECT_LT(jw.at("end_error").get<double>(), 1.0);
  EXPECT_NE(run_cli("lio '" + dir_ + "' --map-window -3 -o '" + out + "'").exit_code, 0);

  // ICP on every frame (a plane threshold no frame reaches), with either metric, with and without
  // the LOAM residuals: valid runs near the truth, and the report names the ICP formulation.
  for (const std::string metric : {"point-to-point", "point-to-distribution"}) {
    for (const bool only : {false, true}) {
      SCOPED_TRACE(metric + (only ? " --icp-only" : ""));
      const test::RunResult ri = run_cli("lio '" + dir_ + "' --mode hybrid --min-plane-points 100000 --icp-metric " +
                                         metric + (only ? " --icp-only" : "") + " -o '" + out + "' --json");
      ASSERT_EQ(ri.exit_code, 0) << ri.err;
      const Json ji = Json::parse(ri.out);
      EXPECT_EQ(ji.at("icp_metric").get<std::string>(), metric);
      EXPECT_EQ(ji.at("icp_keep_loam").get<bool>(), !only);
      EXPECT_EQ(ji.at("frames_per_mode").at("icp").get<std::size_t>(), n - 1);
      EXPECT_LT(ji.at("end_error").get<double>(), 1.0);
    }
  }
  EXPECT_NE(run_cli("lio '" + dir_ + "' --icp-metric point-to-line -o '" + out + "'").exit_code, 0);
}

TEST_F(LioCliTest, ThreadCountDoesNotChangeTheTrajectory) {
  // LOAM association (the default hybrid) and the ICP residuals (a plane threshold no frame
  // reaches), each on 1 and 3 threads (chunks spread unevenly over the threads), over the first 30
  // frames (each frame's queries span several chunks): the same trajectory file byte for byte.
  for (const std::string extra : {"", " --min-plane-points 100000 --icp-metric point-to-distribution"}) {
    SCOPED_TRACE(extra);
    std::vector<std::string> trajectories;
    for (const char* threads : {"1", "3"}) {
      const std::string out = test::temp_path("lio_cli_threads_" + std::string(threads) + "_" + std::to_string(::getpid()));
      fs::remove_all(out);
      const test::RunResult r = run_cli("lio '" + dir_ + "' --mode hybrid --max-frames 30 --threads " + threads + extra + " -o '" + out + "'");
      ASSERT_EQ(r.exit_code, 0) << r.err;
      trajectories.push_back(test::read_text(out + "/trajectory.tum"));
      fs::remove_all(out);
    }
    EXPECT_GT(trajectories[0].size(), 500u);
    EXPECT_EQ(trajectories[1], trajectories[0]);
  }
}

TEST_F(LioCliTest, LoamNeedsNoImuAndStartsAtIdentityWithoutGroundTruth) {
  const std::string dump = copy_without("noimu", {"imu.csv", "gt.tum"});
  const std::string out = test::temp_path("lio_cli_out_loam_" + std::to_string(::getpid()));
  fs::remove_all(out);
  const test::RunResult r = run_cli("lio '" + dump + "' --mode loam -o '" + out + "' --max-frames 12");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("12 frames (loam)"), std::string::npos) << r.out;
  const Trajectory est = io::read_tum(out + "/trajectory.tum");
  ASSERT_EQ(est.size(), 12u);
  EXPECT_TRUE(est.poses.front().isApprox(Eigen::Isometry3d::Identity()));
  // Standing still for the first second: the LiDAR-only estimate stays near identity.
  EXPECT_LT(est.poses.back().translation().norm(), 0.1);
  std::ifstream in(out + "/report.json");
  const Json j = Json::parse(in);
  EXPECT_FALSE(j.contains("end_error"));
  EXPECT_EQ(j.at("frames_per_mode").at("icp").get<std::size_t>(), 0u);
  // An IMU mode on a dump without imu.csv is an error naming the file.
  const test::RunResult bad = run_cli("lio '" + dump + "' --mode loam-imu -o '" + out + "'");
  EXPECT_NE(bad.exit_code, 0);
  EXPECT_NE(bad.err.find("imu.csv"), std::string::npos) << bad.err;
  fs::remove_all(dump);
}

TEST_F(LioCliTest, RejectsBadOptionsAndMissingDumps) {
  const std::string out = test::temp_path("lio_cli_out_bad_" + std::to_string(::getpid()));
  test::RunResult r = run_cli("lio '" + dir_ + "' --mode lego -o '" + out + "'");
  EXPECT_NE(r.exit_code, 0);
  r = run_cli("lio '" + dir_ + "' --mode hybrid");
  EXPECT_NE(r.exit_code, 0);
  r = run_cli("lio '" + dir_ + "' --max-frames -3 -o '" + out + "'");
  EXPECT_NE(r.exit_code, 0);
  r = run_cli("lio '" + dir_ + "' --min-plane-points -1 -o '" + out + "'");
  EXPECT_NE(r.exit_code, 0);
  r = run_cli("lio '" + test::temp_path("no_such_dump") + "' -o '" + out + "'");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("no_such_dump"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace plumb
