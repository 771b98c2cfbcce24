// SPDX-License-Identifier: BSD-3-Clause
// `plumb import` on ROS 2 bags in MCAP written by Foxglove's MCAP and ROS 2 serialization libraries
// (tests/cli/mcap_writer/mcap_from_dump.cjs, run by Node.js) from a simulated frame dump: what
// comes back must be the dump.
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "cli_runner.hpp"
#include "plumb/app/simulate.hpp"
#include "plumb/bim/ifc.hpp"
#include "plumb/bim/mesh.hpp"
#include "plumb/io/frame_dump.hpp"
#include "plumb/io/mcap.hpp"
#include "plumb/io/trajectory.hpp"
#include "plumb/sim/scenario.hpp"
#include "test_data.hpp"

namespace plumb {
namespace {

namespace fs = std::filesystem;
using test::run_cli;
using Json = nlohmann::json;

int run_shell(const std::string& command) {
  const int status = std::system(command.c_str());
  return status != -1 && WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// Node with the writer's pinned modules (scripts/setup.sh installs them there).
std::string node_command() {
  const char* home = std::getenv("HOME");
  return std::string("NODE_PATH='") + (home != nullptr ? home : "") + "/.cache/plumb/mcap-writer/node_modules' node";
}

// Every test of this suite is labelled slow (PLUMB_SLOW_TESTS): they run in one process, which
// simulates the dump and writes each MCAP file once for all of them.
class ImportMcapCliTest : public test::CliTest {
 protected:
  static void SetUpTestSuite() {
    have_writer_ = run_shell(node_command() + " -e \"require('@mcap/core'); require('@foxglove/rosmsg2-serialization'); "
                                              "require('lz4js'); require('@foxglove/wasm-zstd')\" >/dev/null 2>&1") == 0;
    if (!have_writer_) return;
    dir_ = test::temp_path("import_mcap_cli_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    const bim::BimMesh mesh =
        bim::build_mesh(bim::read_ifc(test::source_dir() + "/examples/data/demo_office.ifc"));
    sim::ScenarioSettings s = sim::scenario_defaults(sim::ScenarioKind::kIndoor);
    s.lidar = sim::lidar_preset("vlp16");
    s.length = 2.0;
    s.seed = 5;
    simulate_to_dump(mesh, dump(), s);
  }
  static void TearDownTestSuite() {
    if (!dir_.empty()) fs::remove_all(dir_);
  }
  void SetUp() override {
    test::CliTest::SetUp();
    // Not a skip: without an independent writer the MCAP import would go untested.
    ASSERT_TRUE(have_writer_) << "node cannot load the MCAP writer's modules from ~/.cache/plumb/mcap-writer "
                              << "(Node.js, @mcap/core, @foxglove/rosmsg2-serialization, ...): run scripts/setup.sh";
  }
  static std::string dump() { return dir_ + "/dump"; }
  /// An MCAP file of the dump's first `frames` frames (and all its IMU and odometry).
  static std::string mcap(const std::string& compression, const std::string& layout, int frames,
                          const std::string& options = "") {
    std::string tag = options;
    for (char& c : tag) c = c == ' ' || c == '-' ? '_' : c;
    const std::string path = dir_ + "/" + compression + "_" + layout + "_" + std::to_string(frames) + tag + ".mcap";
    if (!fs::exists(path)) {
      const std::string command = node_command() + " '" + test::source_dir() + "/tests/cli/mcap_writer/mcap_from_dump.cjs' '" +
                                  dump() + "' '" + path + "' --compression " + compression + " --layout " + layout +
                                  " --frames " + std::to_string(frames) + " " + options;
      EXPECT_EQ(run_shell(command), 0) << command;
    }
    return path;
  }
  static test::RunResult import(const std::string& path, const std::string& out, const std::string& args = "") {
    fs::remove_all(out);
    return run_cli("import '" + path + "' -o '" + out + "' " + args);
  }
  static void expect_same_dump(const io::FrameDumpReader& got, const io::FrameDumpReader& want, std::size_t n) {
    ASSERT_EQ(got.num_frames(), n);
    for (std::size_t i = 0; i < n; ++i) {
      EXPECT_NEAR(got.stamp(i), want.stamp(i), 1e-9) << i;
      const PointCloud a = got.frame(i), b = want.frame(i);
      ASSERT_EQ(a.size(), b.size()) << i;
      ASSERT_EQ(a.intensities.size(), b.size());
      ASSERT_EQ(a.rings.size(), b.size());
      ASSERT_EQ(a.times.size(), b.size());
      EXPECT_EQ(std::memcmp(a.points.data(), b.points.data(), a.size() * sizeof(Vector3f)), 0) << i;
      EXPECT_EQ(std::memcmp(a.intensities.data(), b.intensities.data(), a.size() * sizeof(float)), 0) << i;
      EXPECT_EQ(a.rings, b.rings) << i;
      EXPECT_EQ(std::memcmp(a.times.data(), b.times.data(), a.size() * sizeof(float)), 0) << i;
    }
    EXPECT_TRUE(got.meta().T_base_lidar.isApprox(want.meta().T_base_lidar, 1e-12));
    EXPECT_TRUE(got.meta().T_base_imu.isApprox(want.meta().T_base_imu, 1e-12));
    EXPECT_NEAR(got.meta().imu_rate_hz, 200.0, 1e-6);
    EXPECT_NEAR(got.meta().lidar.rate_hz, 10.0, 1e-6);
    const auto imu = got.imu(), imu_want = want.imu();
    ASSERT_EQ(imu.size(), imu_want.size());
    for (std::size_t i = 0; i < imu.size(); ++i) {
      EXPECT_NEAR(imu[i].stamp, imu_want[i].stamp, 1e-9);
      EXPECT_EQ(imu[i].gyro, imu_want[i].gyro);
      EXPECT_EQ(imu[i].accel, imu_want[i].accel);
    }
    const auto odom = got.odometry(), odom_want = want.odometry();
    ASSERT_EQ(odom.size(), odom_want.size());
    for (std::size_t i = 0; i < odom.size(); ++i) {
      EXPECT_NEAR(odom[i].stamp, odom_want[i].stamp, 1e-9);
      EXPECT_EQ(odom[i].pose.x, odom_want[i].pose.x);
      EXPECT_EQ(odom[i].pose.y, odom_want[i].pose.y);
      EXPECT_NEAR(odom[i].pose.theta, odom_want[i].pose.theta, 1e-12);
    }
  }
  static bool have_writer_;
  static std::string dir_;
};
bool ImportMcapCliTest::have_writer_ = false;
std::string ImportMcapCliTest::dir_;

TEST_F(ImportMcapCliTest, EveryVariantGivesBackTheDump) {
  const io::FrameDumpReader want(dump());
  struct Variant {
    const char* compression;
    const char* layout;
    const char* options;
    bool summary;
  };
  const Variant variants[] = {
      {"none", "pcd", "", true},
      {"lz4", "pcd", "", true},
      {"zstd", "pcd", "", true},
      {"zstd", "pcd", "--no-summary", false},
      {"none", "pcd", "--unchunked", true},
      {"none", "pcd", "--unchunked --no-summary", false},
      // Fields reordered, padding, float64 x y z, two rows; big-endian point data in big-endian CDR.
      {"lz4", "unusual", "", true},
      {"lz4", "unusual-be", "--cdr-be", true},
  };
  for (const Variant& v : variants) {
    SCOPED_TRACE(std::string(v.compression) + " " + v.layout + " " + v.options);
    const std::string path = mcap(v.compression, v.layout, 4, v.options);
    EXPECT_EQ(io::McapReader(path).has_summary(), v.summary);
    const std::string out = dir_ + "/imported";
    const test::RunResult r = import(path, out, "--json");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const Json j = Json::parse(r.out);
    EXPECT_EQ(j["frames"], 4);
    EXPECT_EQ(j["lidar"], "/points");
    EXPECT_EQ(j["T_base_lidar_from"], "/tf_static");
    expect_same_dump(io::FrameDumpReader(out), want, 4);
  }
}

TEST_F(ImportMcapCliTest, DriverLayoutsVelodyneAndOuster) {
  const io::FrameDumpReader want(dump());
  const std::string velodyne = dir_ + "/imported_velodyne";
  test::RunResult r = import(mcap("lz4", "velodyne", 3), velodyne);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const io::FrameDumpReader got_velodyne(velodyne);
  ASSERT_EQ(got_velodyne.num_frames(), 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    const PointCloud a = got_velodyne.frame(i), b = want.frame(i);
    ASSERT_EQ(a.size(), b.size()) << i;
    EXPECT_EQ(std::memcmp(a.points.data(), b.points.data(), a.size() * sizeof(Vector3f)), 0) << i;
    EXPECT_EQ(a.rings, b.rings) << i;
    EXPECT_EQ(std::memcmp(a.times.data(), b.times.data(), a.size() * sizeof(float)), 0) << i;
  }
  // `t` in integer nanoseconds, reflectivity beside intensity, a NaN point after every 7th (dropped).
  const std::string ouster = dir_ + "/imported_ouster";
  r = import(mcap("zstd", "ouster", 3), ouster, "--json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const io::FrameDumpReader got(ouster);
  ASSERT_EQ(got.num_frames(), 3u);
  std::size_t nan_points = 0;
  for (std::size_t i = 0; i < 3; ++i) {
    const PointCloud a = got.frame(i), b = want.frame(i);
    ASSERT_EQ(a.size(), b.size()) << i;
    nan_points += (b.size() - 1) / 7;
    EXPECT_EQ(std::memcmp(a.points.data(), b.points.data(), a.size() * sizeof(Vector3f)), 0) << i;
    EXPECT_EQ(std::memcmp(a.intensities.data(), b.intensities.data(), a.size() * sizeof(float)), 0) << i;
    EXPECT_EQ(a.rings, b.rings) << i;
    for (std::size_t k = 0; k < a.size(); ++k) ASSERT_NEAR(a.times[k], b.times[k], 1e-9) << i << ' ' << k;
  }
  EXPECT_EQ(Json::parse(r.out)["nonfinite_points"], nan_points);
}

TEST_F(ImportMcapCliTest, ListCountsWhatTheFileHolds) {
  const io::FrameDumpReader want(dump());
  const std::string path = mcap("zstd", "pcd", 6);
  const test::RunResult r = run_cli("import '" + path + "' --list --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const Json j = Json::parse(r.out);
  EXPECT_EQ(j["format"], "MCAP (ROS 2)");
  std::map<std::string, std::pair<std::string, std::uint64_t>> topics;
  for (const Json& t : j["topics"]) topics[t["topic"]] = {t["type"], t["messages"]};
  ASSERT_EQ(topics.size(), 4u);
  EXPECT_EQ(topics["/points"], std::make_pair(std::string("sensor_msgs/msg/PointCloud2"), std::uint64_t{6}));
  EXPECT_EQ(topics["/imu"], std::make_pair(std::string("sensor_msgs/msg/Imu"), std::uint64_t{want.imu().size()}));
  EXPECT_EQ(topics["/odom"], std::make_pair(std::string("nav_msgs/msg/Odometry"), std::uint64_t{want.odometry().size()}));
  EXPECT_EQ(topics["/tf_static"], std::make_pair(std::string("tf2_msgs/msg/TFMessage"), std::uint64_t{1}));
  EXPECT_EQ(j["messages"], 6 + want.imu().size() + want.odometry().size() + 1);
  EXPECT_EQ(j["compression"]["zstd"], j["chunks"]);
  EXPECT_NEAR(j["start"].get<double>(), want.imu().front().stamp, 1e-9);
  for (const Json& t : j["topics"]) {
    if (t["topic"] == "/imu") {
      EXPECT_NEAR(t["rate_hz"].get<double>(), 200.0, 1e-6);
    }
    if (t["topic"] == "/points") {
      EXPECT_NEAR(t["last"].get<double>(), want.stamp(5), 1e-9);
    }
  }
  // Without a summary the same counts come from scanning the file.
  const test::RunResult scanned = run_cli("import '" + mcap("lz4", "pcd", 6, "--no-summary") + "' --list --json");
  ASSERT_EQ(scanned.exit_code, 0) << scanned.err;
  EXPECT_EQ(Json::parse(scanned.out)["topics"], j["topics"]);
  const test::RunResult text = run_cli("import '" + path + "' --list");
  ASSERT_EQ(text.exit_code, 0) << text.err;
  EXPECT_NE(text.out.find("format:      MCAP (ROS 2)"), std::string::npos) << text.out;
  EXPECT_NE(text.out.find("6 msgs @    10.00 Hz : sensor_msgs/msg/PointCloud2"), std::string::npos) << text.out;
}

std::string mcap_bytes(const std::string& from, const std::string& to, std::size_t keep) {
  std::string bytes = test::read_text(from);
  bytes.resize(std::min(bytes.size(), keep));
  std::ofstream(to, std::ios::binary) << bytes;
  return bytes;
}

TEST_F(ImportMcapCliTest, ATruncatedFileFailsNamingFileAndOffset) {
  for (const char* options : {"", "--no-summary"}) {
    const std::string whole = mcap("lz4", "pcd", 6, options);
    const std::size_t size = fs::file_size(whole);
    for (const std::size_t keep : {std::size_t{5}, std::size_t{30}, std::size_t{5000}, size / 2, size - 10}) {
      SCOPED_TRACE(std::string(options) + " " + std::to_string(keep));
      const std::string cut = dir_ + "/cut.mcap";
      mcap_bytes(whole, cut, keep);
      const test::RunResult r = import(cut, dir_ + "/imported_cut");
      EXPECT_EQ(r.exit_code, 1);
      EXPECT_NE(r.err.find(cut + ": offset "), std::string::npos) << r.err;
      EXPECT_FALSE(fs::exists(dir_ + "/imported_cut"));
    }
  }
}

TEST_F(ImportMcapCliTest, ACorruptChunkFailsNamingItsOffset) {
  // lz4 and zstd find the damage in their data; an uncompressed chunk by its CRC32.
  for (const char* compression : {"none", "lz4", "zstd"}) {
    SCOPED_TRACE(compression);
    std::string bytes = test::read_text(mcap(compression, "pcd", 6));
    for (std::size_t i = 3000; i < 3400; ++i) bytes[i] = static_cast<char>(bytes[i] ^ 0x5a);
    const std::string bad = dir_ + "/corrupt_" + compression + ".mcap";
    std::ofstream(bad, std::ios::binary) << bytes;
    const test::RunResult r = import(bad, dir_ + "/imported_corrupt");
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_NE(r.err.find(bad + ": offset "), std::string::npos) << r.err;
    if (std::string(compression) == "none") {
      EXPECT_NE(r.err.find("CRC32"), std::string::npos) << r.err;
    }
  }
}

TEST_F(ImportMcapCliTest, AnotherTypeOrEncodingIsRefusedNamingTheTopic) {
  // Unchunked and without a summary: the schemas are plain bytes of the file, under no CRC.
  const std::string from = "sensor_msgs/msg/Imu", to = "sensor_msgs/msg/Imx";
  auto retyped = [&](const std::string& options) {
    std::string bytes = test::read_text(mcap("none", "pcd", 2, options));
    for (std::size_t at = bytes.find(from); at != std::string::npos; at = bytes.find(from, at)) {
      bytes.replace(at, from.size(), to);
    }
    const std::string bad = dir_ + "/other_type.mcap";
    std::ofstream(bad, std::ios::binary) << bytes;
    return bad;
  };
  std::string bad = retyped("--unchunked --no-summary");
  test::RunResult r = import(bad, dir_ + "/imported_type", "--imu /imu");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find(bad + ": topic /imu has type sensor_msgs/msg/Imx, expected sensor_msgs/msg/Imu"), std::string::npos)
      << r.err;
  // With a summary, its CRC32 (the writer's) sees the change there.
  bad = retyped("--unchunked");
  r = import(bad, dir_ + "/imported_type");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find(bad + ": offset "), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("summary CRC32"), std::string::npos) << r.err;
  // A ROS 2 sqlite3 bag: not read, with the way to MCAP.
  const std::string db3 = dir_ + "/bag_0.db3";
  std::ofstream(db3, std::ios::binary) << std::string("SQLite format 3\0", 16) << std::string(100, '\0');
  r = import(db3, dir_ + "/imported_db3");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find(db3 + ": offset 0: a ROS 2 bag in sqlite3"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("ros2 bag convert"), std::string::npos) << r.err;
}

TEST_F(ImportMcapCliTest, WheelAnglesFromJointState) {
  const io::FrameDumpReader want(dump());
  const std::string out = dir_ + "/imported_wheels";
  const test::RunResult r =
      import(mcap("zstd", "pcd", 3, "--wheels"), out, "--wheels /joint_states --wheel-joints wheel_left wheel_right --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto got = io::FrameDumpReader(out).wheels(), expected = want.wheels();
  EXPECT_EQ(Json::parse(r.out)["wheel_readings"], expected.size());
  ASSERT_EQ(got.size(), expected.size());
  for (std::size_t i = 0; i < got.size(); ++i) {
    EXPECT_NEAR(got[i].stamp, expected[i].stamp, 1e-9) << i;
    EXPECT_EQ(got[i].left, expected[i].left) << i;
    EXPECT_EQ(got[i].right, expected[i].right) << i;
  }
}

// Two LIO runs.
TEST_F(ImportMcapCliTest, HybridLioOnTheImportedDumpFollowsTheOriginal) {
  constexpr int kFrames = 20;
  const std::string out = dir_ + "/imported_lio";
  const test::RunResult imported = import(mcap("zstd", "pcd", kFrames), out);
  ASSERT_EQ(imported.exit_code, 0) << imported.err;
  fs::copy_file(dump() + "/gt.tum", out + "/gt.tum");
  const std::string frames = " --max-frames " + std::to_string(kFrames);
  test::RunResult r = run_cli("lio '" + dump() + "' --mode hybrid -o '" + dir_ + "/lio_original'" + frames);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = run_cli("lio '" + out + "' --mode hybrid -o '" + dir_ + "/lio_imported'" + frames);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const Trajectory a = io::read_tum(dir_ + "/lio_imported/trajectory.tum");
  const Trajectory b = io::read_tum(dir_ + "/lio_original/trajectory.tum");
  ASSERT_EQ(a.size(), static_cast<std::size_t>(kFrames));
  ASSERT_EQ(b.size(), a.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_NEAR(a.stamps[i], b.stamps[i], 1e-9);
    EXPECT_LT((a.poses[i].translation() - b.poses[i].translation()).norm(), 1e-3) << i;
  }
}

}  // namespace
}  // namespace plumb
