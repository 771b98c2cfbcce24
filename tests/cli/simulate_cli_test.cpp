// SPDX-License-Identifier: BSD-3-Clause
// `plumb simulate` on a real IFC building, as a user runs it.
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "cli_runner.hpp"
#include "plumb/io/frame_dump.hpp"
#include "test_data.hpp"

namespace plumb {
namespace {

using test::CliTest;
using test::run_cli;
using Json = nlohmann::json;

/// A coarse custom LiDAR as a user would describe it.
std::string write_lidar_json(const std::string& name) {
  const std::string path = test::temp_path(name + ".json");
  std::ofstream(path) << R"({"name": "tiny", "elevations_deg": [-15, -7, 0, 7], "columns": 60, "rate_hz": 10,
                             "min_range": 0.3, "max_range": 60, "range_sigma": 0.01, "dropout": 0.0})";
  return path;
}

TEST_F(CliTest, SimulateWritesAFrameDumpAndAJsonSummary) {
  PLUMB_REQUIRE_DATA(model, "ifc/buildings/AC20-FZK-Haus.ifc");
  const std::string dir = test::temp_path("cli_simulate_dump");
  std::filesystem::remove_all(dir);
  const test::RunResult r = run_cli("simulate '" + model + "' -o '" + dir + "' --lidar '" +
                                    write_lidar_json("cli_simulate_lidar") + "' --length 2 --loops 1 --seed 3 --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const Json j = Json::parse(r.out);
  EXPECT_EQ(j.at("scenario"), "indoor");
  EXPECT_EQ(j.at("lidar"), "tiny");
  EXPECT_NEAR(j.at("path_length").get<double>(), 2.0, 0.5);
  EXPECT_GT(j.at("seconds").get<double>(), 0.0);
  const io::FrameDumpReader dump(dir);
  EXPECT_EQ(dump.num_frames(), j.at("frames").get<std::size_t>());
  EXPECT_EQ(dump.meta().lidar.columns, 60);
  EXPECT_TRUE(dump.has_imu() && dump.has_wheels() && dump.has_odometry() && dump.has_ground_truth() &&
              dump.has_ground_truth_dense());
  EXPECT_EQ(dump.frame(0).rings.size(), dump.frame(0).size());
  // No progress bar when stderr is not a terminal.
  EXPECT_EQ(r.err.find('#'), std::string::npos) << r.err;
  // A second run into the same directory refuses to overwrite it.
  const test::RunResult again = run_cli("simulate '" + model + "' -o '" + dir + "' --length 1");
  EXPECT_NE(again.exit_code, 0);
  EXPECT_NE(again.err.find("overwrite"), std::string::npos) << again.err;
}

TEST_F(CliTest, SimulateRejectsBadInput) {
  PLUMB_REQUIRE_DATA(model, "ifc/unit/basic_shape_SweptSolid.ifc");
  const std::string dir = test::temp_path("cli_simulate_bad");
  std::filesystem::remove_all(dir);
  test::RunResult r = run_cli("simulate '" + model + "' -o '" + dir + "' --length 1");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_TRUE(r.err.find("walkable") != std::string::npos || r.err.find("storey") != std::string::npos) << r.err;
  r = run_cli("simulate '" + model + "' -o '" + dir + "' --scenario moon");
  EXPECT_NE(r.exit_code, 0);
  r = run_cli("simulate '" + model + "' -o '" + dir + "' --lidar hdl64");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("hdl64"), std::string::npos) << r.err;
  const std::string bad_json = test::temp_path("cli_simulate_bad_lidar.json");
  std::ofstream(bad_json) << "{\"columns\": 10,";
  r = run_cli("simulate '" + model + "' -o '" + dir + "' --lidar '" + bad_json + "'");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("cli_simulate_bad_lidar.json"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace plumb
