// SPDX-License-Identifier: BSD-3-Clause
// The numbered library examples run as a user runs them: 01 on its own synthetic room, 02 (frames fed
// one by one into BimLocalizer + BimOdometry) on a short simulated run in the demo office, its last
// pose checked against the dump's exact ground truth; 02 without arguments prints its usage.
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "cli_runner.hpp"
#include "plumb/io/frame_dump.hpp"
#include "test_data.hpp"

namespace plumb {
namespace {

using test::CliTest;
using test::run_cli;

/// Run examples/NN_name (built next to the CLI) with ARGS.
test::RunResult run_example(const std::string& name, const std::string& args) {
  return test::run_program(test::binary_dir() + "/examples/plumb_example_" + name, args);
}

TEST_F(CliTest, Example01CloudBasicsRuns) {
  const test::RunResult r = run_example("01_cloud_basics", "");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("wrote and read"), std::string::npos) << r.out;
}

TEST_F(CliTest, Example02FeedsFramesAndEndsNearTheTruth) {
  const std::string model = test::source_dir() + "/examples/data/demo_office.ifc";
  const std::string dir = test::temp_path("example02_dump_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  ASSERT_EQ(run_cli("simulate '" + model + "' -o '" + dir + "' --length 4 --seed 2").exit_code, 0);
  const test::RunResult r = run_example("02_bim_odometry", "'" + model + "' '" + dir + "'");
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  // "last frame N: t T s, x X m, y Y m, yaw A deg, BIM anchor D"
  const std::size_t at = r.out.rfind("last frame ");
  ASSERT_NE(at, std::string::npos) << r.out;
  std::size_t frame = 0;
  double t = 0, x = 0, y = 0, yaw = 0;
  ASSERT_EQ(std::sscanf(r.out.c_str() + at, "last frame %zu: t %lf s, x %lf m, y %lf m, yaw %lf deg", &frame, &t, &x, &y,
                        &yaw),
            5)
      << r.out;
  const io::FrameDumpReader dump(dir);
  ASSERT_EQ(frame + 1, dump.num_frames());
  const Eigen::Isometry3d truth = dump.ground_truth().poses.back();
  EXPECT_LT(std::hypot(x - truth.translation().x(), y - truth.translation().y()), 0.05) << r.out;
  const double truth_yaw = std::atan2(truth.linear()(1, 0), truth.linear()(0, 0)) * 180.0 / M_PI;
  EXPECT_LT(std::abs(std::remainder(yaw - truth_yaw, 360.0)), 0.5) << r.out;
  std::filesystem::remove_all(dir);
}

TEST_F(CliTest, Example02WithoutArgumentsPrintsUsage) {
  const test::RunResult r = run_example("02_bim_odometry", "");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("usage:"), std::string::npos) << r.err;
}

TEST_F(CliTest, Example02ReportsAMissingDump) {
  const std::string model = test::source_dir() + "/examples/data/demo_office.ifc";
  const test::RunResult r = run_example("02_bim_odometry", "'" + model + "' /nonexistent/dump");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("error:"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace plumb
