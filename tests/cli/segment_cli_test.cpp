// SPDX-License-Identifier: BSD-3-Clause
// `plumb segment` on real frames, as a user runs it: JSON keys, the labels file against the library
// call, the scan CSV, and bad input.
#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "cli_runner.hpp"
#include "plumb/io/cloud_io.hpp"
#include "plumb/scan2d/cloud_to_scan.hpp"
#include "plumb/segmentation/segment_frame.hpp"
#include "test_data.hpp"

namespace plumb {
namespace {

using test::CliTest;
using test::run_cli;
using Json = nlohmann::json;

std::vector<std::string> read_lines(const std::string& path) {
  std::ifstream in(path);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

TEST_F(CliTest, SegmentRoomScanJsonAndLabelsMatchTheLibrary) {
  PLUMB_REQUIRE_DATA(path, "cloud3d/pcl_room_scans/room_scan1.pcd");
  const std::string labels_path = test::temp_path("segment_room_labels.txt");
  const test::RunResult r = run_cli("segment '" + path + "' --json --labels-out '" + labels_path + "'");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const Json j = Json::parse(r.out);
  EXPECT_EQ(j.at("status"), "ok");
  const Json& g = j.at("ground");
  ASSERT_EQ(g.at("normal").size(), 3u);
  EXPECT_GT(g.at("normal")[2].get<double>(), 0.99);
  EXPECT_NEAR(g.at("offset").get<double>(), -1.3, 0.1);  // the floor, 1.3 m below the scanner
  EXPECT_GE(j.at("vertical").at("num_planes").get<int>(), 2);
  EXPECT_GT(j.at("seconds").get<double>(), 0.0);
  const std::size_t ng = g.at("num_points"), nv = j.at("vertical").at("num_points"),
                    nd = j.at("decoration").at("num_points");
  EXPECT_EQ(ng + nv + nd, 112586u);

  const PointCloud cloud = io::read_cloud(path);
  const SegmentResult lib = segment_frame(cloud);
  const std::vector<std::string> lines = read_lines(labels_path);
  ASSERT_EQ(lines.size(), cloud.size());
  std::size_t mismatches = 0, ground = 0;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    mismatches += std::stoi(lines[i]) != lib.labels[i] ? 1 : 0;
    ground += lines[i] == "1" ? 1 : 0;
  }
  EXPECT_EQ(mismatches, 0u);
  EXPECT_EQ(ground, ng);
}

TEST_F(CliTest, SegmentWithSensorHeightAndScanCsv) {
  PLUMB_REQUIRE_DATA(path, "cloud3d/hdl32_pair/251370668.pcd");
  const std::string scan_path = test::temp_path("segment_hdl32_scan.csv");
  const test::RunResult r = run_cli("segment '" + path + "' --sensor-height 2.0 --json --scan-out '" + scan_path + "'");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const Json j = Json::parse(r.out);
  EXPECT_EQ(j.at("status"), "ok");
  EXPECT_NEAR(j.at("ground").at("offset").get<double>(), -2.0, 0.3);
  const std::vector<std::string> lines = read_lines(scan_path);
  const CloudToScanResult scan = cloud_to_scan(io::read_cloud(path));
  ASSERT_EQ(lines.size(), scan.scan.size() + 1);
  EXPECT_EQ(lines[0], "beam,angle,range,x,y");
  std::size_t valid = 0;
  for (std::size_t b = 0; b < scan.scan.size(); ++b) {
    std::stringstream ss(lines[b + 1]);
    std::string beam, angle, range;
    std::getline(ss, beam, ',');
    std::getline(ss, angle, ',');
    std::getline(ss, range, ',');
    EXPECT_EQ(std::stoul(beam), b);
    EXPECT_NEAR(std::stod(angle), scan.scan.angle(b), 1e-6);
    if (std::isinf(scan.scan.ranges[b])) {
      EXPECT_EQ(range, "inf");
    } else {
      EXPECT_NEAR(std::stod(range), scan.scan.ranges[b], 1e-5);
      ++valid;
    }
  }
  EXPECT_GT(valid, 100u);
}

TEST_F(CliTest, SegmentAllNanFrameReportsNoGround) {
  PointCloud nan;
  nan.points.assign(50, Vector3f::Constant(std::numeric_limits<float>::quiet_NaN()));
  const std::string path = test::temp_path("segment_all_nan.pcd");
  io::write_cloud(path, nan);
  const std::string labels_path = test::temp_path("segment_all_nan_labels.txt");
  const test::RunResult r = run_cli("segment '" + path + "' --json --labels-out '" + labels_path + "'");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const Json j = Json::parse(r.out);
  EXPECT_EQ(j.at("status"), "insufficient_data");
  EXPECT_TRUE(j.at("ground").at("normal").is_null());
  EXPECT_EQ(j.at("decoration").at("num_points").get<int>(), 50);
  const std::vector<std::string> lines = read_lines(labels_path);
  ASSERT_EQ(lines.size(), 50u);
  for (const std::string& l : lines) EXPECT_EQ(l, "0");
}

TEST_F(CliTest, SegmentBadInputFails) {
  EXPECT_NE(run_cli("segment /nonexistent/frame.pcd").exit_code, 0);
  PLUMB_REQUIRE_DATA(path, "cloud3d/pcl_test/bunny.pcd");
  EXPECT_NE(run_cli("segment '" + path + "' --sensor-height -1").exit_code, 0);
  const std::string bad = test::temp_path("segment_bad.pcd");
  {
    std::ofstream out(bad);
    out << "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 5\n";
  }
  const test::RunResult r = run_cli("segment '" + bad + "'");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_FALSE(r.err.empty());
}

}  // namespace
}  // namespace plumb
