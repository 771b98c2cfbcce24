// SPDX-License-Identifier: BSD-3-Clause
// Runs the built `plumb` binary (${PLUMB_BINARY_DIR}/examples/plumb) as a user would.

#include <sys/wait.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <string>

#include <gtest/gtest.h>

#include "plumb/core/lie.hpp"
#include "plumb/io/trajectory.hpp"
#include "plumb/version.hpp"
#include "cli_runner.hpp"
#include "test_data.hpp"

namespace plumb {
namespace {

using test::CliTest;
using test::json_number;
using test::read_text;
using test::RunResult;

RunResult run(const std::string& args) { return test::run_cli(args); }

TEST_F(CliTest, HelpListsSubcommands) {
  const RunResult r = run("--help");
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_NE(r.out.find("eval"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("Evaluate a trajectory"), std::string::npos) << r.out;
  const RunResult sub = run("eval --help");
  EXPECT_EQ(sub.exit_code, 0);
  EXPECT_NE(sub.out.find("--rpe-delta"), std::string::npos);
}

TEST_F(CliTest, VersionPrintsVersion) {
  const RunResult r = run("--version");
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_NE(r.out.find(PLUMB_VERSION_STRING), std::string::npos) << r.out;
}

TEST_F(CliTest, EvalKitti00JsonMatchesEvo) {
  PLUMB_REQUIRE_DATA(est, "trajectories/kitti00/KITTI_00_ORB.txt");
  PLUMB_REQUIRE_DATA(ref, "trajectories/kitti00/KITTI_00_gt.txt");
  PLUMB_REQUIRE_DATA(times, "trajectories/kitti00/KITTI_00_gt_times.txt");
  const std::string ape_ref = read_text(test::data_path("trajectories/kitti00/evo_reference/orb_ape_stats.json"));
  const std::string rpe_ref = read_text(test::data_path("trajectories/kitti00/evo_reference/orb_rpe_stats.json"));
  const RunResult r = run("eval '" + est + "' '" + ref + "' --format kitti --align se3 --rpe-delta 10 --rpe-unit m "
                          "--json --ref-times '" + times + "'");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(r.err.empty()) << r.err;
  // Exactly one JSON object on one line.
  ASSERT_FALSE(r.out.empty());
  EXPECT_EQ(r.out.front(), '{');
  EXPECT_EQ(r.out.substr(r.out.size() - 2), "}\n");
  EXPECT_EQ(r.out.find('\n'), r.out.size() - 1);
  // Absolute tolerance 1e-6 on each statistic.
  for (const char* key : {"rmse", "mean", "median", "std", "min", "max"}) {
    EXPECT_NEAR(json_number(r.out, "ape", key), json_number(ape_ref, "", key), 1e-6) << "ape " << key;
    EXPECT_NEAR(json_number(r.out, "rpe", key), json_number(rpe_ref, "", key), 1e-6) << "rpe " << key;
  }
  const double drift = json_number(r.out, "", "drift_pct");
  EXPECT_TRUE(std::isfinite(drift));
  EXPECT_GT(drift, 0.0);
  EXPECT_LT(drift, 1.0);
}

TEST_F(CliTest, EvalTumKnownOffsetTableAndJson) {
  // Reference: a circle; estimate: the same shifted 0.3 m along x. No alignment -> APE 0.3 m
  // everywhere, RPE 0, drift at the end 0.3 / path length.
  Trajectory ref, est;
  for (int i = 0; i <= 100; ++i) {
    const double a = 0.06 * i;
    const Eigen::Isometry3d T = se3::make(so3::exp(Vector3d(0, 0, a)), Vector3d(5 * std::cos(a), 5 * std::sin(a), 0));
    ref.push_back(100.0 + 0.1 * i, T);
    Eigen::Isometry3d shifted = T;
    shifted.translation().x() += 0.3;
    est.push_back(100.0 + 0.1 * i + 0.004, shifted);  // 4 ms stamp offset: associated
  }
  const std::string ref_path = test::temp_path("cli_ref.tum");
  const std::string est_path = test::temp_path("cli_est.tum");
  io::write_tum(ref, ref_path);
  io::write_tum(est, est_path);
  const RunResult json = run("eval '" + est_path + "' '" + ref_path + "' --format tum --align none --json");
  ASSERT_EQ(json.exit_code, 0) << json.err;
  EXPECT_NEAR(json_number(json.out, "ape", "rmse"), 0.3, 1e-12);
  EXPECT_NEAR(json_number(json.out, "ape", "min"), 0.3, 1e-12);
  EXPECT_NEAR(json_number(json.out, "rpe", "max"), 0.0, 1e-12);
  const double path = 100 * 2 * 5 * std::sin(0.03);  // 100 chords of 0.06 rad on r = 5
  EXPECT_NEAR(json_number(json.out, "", "drift_pct"), 0.3 / path * 100, 1e-9);
  const RunResult table = run("eval '" + est_path + "' '" + ref_path + "' --align none");
  ASSERT_EQ(table.exit_code, 0) << table.err;
  EXPECT_NE(table.out.find("APE trans [m]"), std::string::npos) << table.out;
  EXPECT_NE(table.out.find("RPE trans [m]"), std::string::npos) << table.out;
  EXPECT_NE(table.out.find("drift at the end"), std::string::npos) << table.out;
}

TEST_F(CliTest, MissingFileFailsWithMessage) {
  const std::string missing = test::temp_path("cli_no_such_file.txt");
  std::remove(missing.c_str());
  const RunResult r = run("eval '" + missing + "' '" + missing + "' --format kitti");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find(missing), std::string::npos) << r.err;
  EXPECT_TRUE(r.out.empty()) << r.out;
}

TEST_F(CliTest, MalformedLineFailsNamingFileAndLine) {
  const std::string bad = test::temp_path("cli_bad.kitti");
  {
    std::ofstream out(bad);
    out << "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 0 0 0 1\n";
  }
  PLUMB_REQUIRE_DATA(ref, "trajectories/kitti00/KITTI_00_gt.txt");
  const RunResult r = run("eval '" + bad + "' '" + ref + "' --format kitti --json");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find(bad + ":2:"), std::string::npos) << r.err;
  EXPECT_TRUE(r.out.empty()) << r.out;
}

TEST_F(CliTest, UsageErrorsFail) {
  for (const char* args : {"eval a b --no-such-option", "eval a b --format xyz", "eval a", "", "nosuchcommand",
                           "eval a b --rpe-delta -1"}) {
    const RunResult r = run(args);
    EXPECT_NE(r.exit_code, 0) << args;
    EXPECT_GT(r.exit_code, 0) << args;  // an exit code, not a signal
    EXPECT_FALSE(r.err.empty()) << args;
    EXPECT_EQ(r.err.find("terminate"), std::string::npos) << r.err;
  }
}

TEST_F(CliTest, MismatchedSizesWithoutStampsFail) {
  const std::string a = test::temp_path("cli_a.kitti");
  const std::string b = test::temp_path("cli_b.kitti");
  {
    std::ofstream(a) << "1 0 0 0 0 1 0 0 0 0 1 0\n";
    std::ofstream(b) << "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 1 0 1 0 0 0 0 1 0\n";
  }
  const RunResult r = run("eval '" + a + "' '" + b + "' --format kitti");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("paired by index"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace plumb
