// SPDX-License-Identifier: BSD-3-Clause
// `plumb import` on ROS 1 bags written by ROS's own rosbag (Debian python3-rosbag, driven by
// tests/cli/bag_from_dump.py) from a simulated frame dump: what comes back must be the dump.
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
#include "plumb/io/ros_messages.hpp"
#include "plumb/io/trajectory.hpp"
#include "plumb/sim/scenario.hpp"
#include "test_data.hpp"

namespace plumb {
namespace {

namespace fs = std::filesystem;
using test::run_cli;
using Json = nlohmann::json;

const char* kPython = "/usr/bin/python3";

int shell(const std::string& command) {
  const int status = std::system(command.c_str());
  return status != -1 && WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// Every test of this suite is labelled slow (PLUMB_SLOW_TESTS): they run in one process, which
// simulates the dump and writes each bag once for all of them.
class ImportCliTest : public test::CliTest {
 protected:
  static void SetUpTestSuite() {
    have_rosbag_ = shell(std::string(kPython) +
                         " -c 'import rosbag, numpy, sensor_msgs.msg, nav_msgs.msg, tf2_msgs.msg' >/dev/null 2>&1") == 0;
    if (!have_rosbag_) return;
    dir_ = test::temp_path("import_cli_" + std::to_string(::getpid()));
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
    // Not a skip: without ROS's own writer `plumb import` would go untested.
    ASSERT_TRUE(have_rosbag_) << kPython << " cannot import rosbag and the ROS message packages (Debian "
                              << "python3-rosbag, python3-sensor-msgs, python3-nav-msgs, python3-tf2-msgs): "
                              << "run scripts/setup.sh";
  }
  static std::string dump() { return dir_ + "/dump"; }
  /// A bag of the dump's first `frames` frames (and all its IMU and odometry), written by rosbag.
  static std::string bag(const std::string& compression, const std::string& layout, int frames,
                         const std::string& options = "") {
    std::string tag = options;
    for (char& c : tag) c = c == ' ' || c == '-' ? '_' : c;
    const std::string path = dir_ + "/" + compression + "_" + layout + "_" + std::to_string(frames) + tag + ".bag";
    if (!fs::exists(path)) {
      const std::string command = std::string(kPython) + " '" + test::source_dir() + "/tests/cli/bag_from_dump.py' '" +
                                  dump() + "' '" + path + "' --compression " + compression + " --layout " + layout +
                                  " --frames " + std::to_string(frames) + " " + options;
      EXPECT_EQ(shell(command), 0) << command;
    }
    return path;
  }
  /// `plumb import BAG -o DIR ARGS`; the result's dump directory is `out`.
  static test::RunResult import(const std::string& bag_path, const std::string& out, const std::string& args = "") {
    fs::remove_all(out);
    return run_cli("import '" + bag_path + "' -o '" + out + "' " + args);
  }
  static void expect_same_frames(const io::FrameDumpReader& got, const io::FrameDumpReader& want, std::size_t n) {
    ASSERT_EQ(got.num_frames(), n);
    for (std::size_t i = 0; i < n; ++i) {
      EXPECT_NEAR(got.stamp(i), want.stamp(i), 1e-9) << i;
      const PointCloud a = got.frame(i), b = want.frame(i);
      ASSERT_EQ(a.size(), b.size()) << i;
      ASSERT_EQ(a.intensities.size(), b.size());
      ASSERT_EQ(a.rings.size(), b.size());
      ASSERT_EQ(a.times.size(), b.size());
      // Bit-identical: the bag carries the floats as they are.
      EXPECT_EQ(std::memcmp(a.points.data(), b.points.data(), a.size() * sizeof(Vector3f)), 0) << i;
      EXPECT_EQ(std::memcmp(a.intensities.data(), b.intensities.data(), a.size() * sizeof(float)), 0) << i;
      EXPECT_EQ(a.rings, b.rings) << i;
      EXPECT_EQ(std::memcmp(a.times.data(), b.times.data(), a.size() * sizeof(float)), 0) << i;
    }
  }
  static bool have_rosbag_;
  static std::string dir_;
};
bool ImportCliTest::have_rosbag_ = false;
std::string ImportCliTest::dir_;

TEST_F(ImportCliTest, EveryCompressionGivesBackTheDump) {
  const io::FrameDumpReader want(dump());
  for (const char* compression : {"none", "bz2", "lz4"}) {
    SCOPED_TRACE(compression);
    const std::string out = dir_ + "/imported_" + compression;
    const test::RunResult r = import(bag(compression, "pcd", 6), out, "--json");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const Json j = Json::parse(r.out);
    EXPECT_EQ(j["frames"], 6);
    EXPECT_EQ(j["T_base_lidar_from"], "/tf_static");
    const io::FrameDumpReader got(out);
    expect_same_frames(got, want, 6);
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
}

TEST_F(ImportCliTest, UnusualLayoutsDecodeTheSamePoints) {
  const io::FrameDumpReader want(dump());
  // Fields reordered, padding in point_step and at the rows' ends, float64 x y z, two rows; either byte order.
  for (const char* layout : {"unusual", "unusual-be"}) {
    SCOPED_TRACE(layout);
    const std::string out = dir_ + "/imported_" + layout;
    const test::RunResult r = import(bag("lz4", layout, 3), out);
    ASSERT_EQ(r.exit_code, 0) << r.err;
    expect_same_frames(io::FrameDumpReader(out), want, 3);
  }
}

TEST_F(ImportCliTest, ListCountsWhatTheBagHolds) {
  const io::FrameDumpReader want(dump());
  const test::RunResult r = run_cli("import '" + bag("bz2", "pcd", 6) + "' --list --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const Json j = Json::parse(r.out);
  std::map<std::string, std::pair<std::string, std::uint64_t>> topics;
  for (const Json& t : j["topics"]) topics[t["topic"]] = {t["type"], t["messages"]};
  ASSERT_EQ(topics.size(), 4u);
  EXPECT_EQ(topics["/points"], std::make_pair(std::string("sensor_msgs/PointCloud2"), std::uint64_t{6}));
  EXPECT_EQ(topics["/imu"], std::make_pair(std::string("sensor_msgs/Imu"), std::uint64_t{want.imu().size()}));
  EXPECT_EQ(topics["/odom"], std::make_pair(std::string("nav_msgs/Odometry"), std::uint64_t{want.odometry().size()}));
  EXPECT_EQ(topics["/tf_static"], std::make_pair(std::string("tf2_msgs/TFMessage"), std::uint64_t{1}));
  EXPECT_EQ(j["messages"], 6 + want.imu().size() + want.odometry().size() + 1);
  EXPECT_EQ(j["compression"]["bz2"], j["chunks"]);
  for (const Json& t : j["topics"]) {
    if (t["topic"] == "/imu") {
      EXPECT_NEAR(t["rate_hz"].get<double>(), 200.0, 1e-6);
    }
  }
  const test::RunResult text = run_cli("import '" + bag("bz2", "pcd", 6) + "' --list");
  ASSERT_EQ(text.exit_code, 0) << text.err;
  EXPECT_NE(text.out.find("/points"), std::string::npos);
  EXPECT_NE(text.out.find("6 msgs @"), std::string::npos) << text.out;
}

TEST_F(ImportCliTest, TheKnownMd5sumsAreRosOwn) {
  const std::string out = dir_ + "/md5.txt";
  ASSERT_EQ(shell(std::string(kPython) +
                  " -c 'from sensor_msgs.msg import PointCloud2, Imu, JointState; from nav_msgs.msg import Odometry; "
                  "from tf2_msgs.msg import TFMessage; print(PointCloud2._md5sum, Imu._md5sum, Odometry._md5sum, "
                  "TFMessage._md5sum, JointState._md5sum)' > '" + out + "'"),
            0);
  EXPECT_EQ(test::read_text(out), std::string(io::kRosPointCloud2Md5) + " " + io::kRosImuMd5 + " " +
                                      io::kRosOdometryMd5 + " " + io::kRosTfMessageMd5 + " " +
                                      io::kRosJointStateMd5 + "\n");
}

TEST_F(ImportCliTest, StartAndDurationCutTheRecording) {
  const std::string out = dir_ + "/imported_cut";
  const test::RunResult r = import(bag("none", "pcd", 6), out, "--start 0.25 --duration 0.3");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const io::FrameDumpReader got(out);
  ASSERT_EQ(got.num_frames(), 3u);
  EXPECT_NEAR(got.stamp(0), 0.3, 1e-9);
  EXPECT_NEAR(got.stamp(2), 0.5, 1e-9);
  for (const auto& s : got.imu()) {
    EXPECT_GE(s.stamp, 0.25 - 1e-9);
    EXPECT_LE(s.stamp, 0.55 + 1e-9);
  }
}

TEST_F(ImportCliTest, ExtrinsicsFromOptionsOrAnErrorNamingTheFrame) {
  const std::string path = bag("none", "pcd", 6);
  const std::string out = dir_ + "/imported_extrinsics";
  test::RunResult r = import(path, out, "--base-frame chassis");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("chassis to 'lidar'"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("--T-base-lidar"), std::string::npos) << r.err;
  r = import(path, out, "--base-frame chassis --T-base-lidar 1 2 3 0 0 1.5707963267948966 --T-base-imu 0 0 0.5 0 0 0");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const io::FrameDumpReader got(out);
  EXPECT_TRUE(got.meta().T_base_lidar.translation().isApprox(Eigen::Vector3d(1, 2, 3)));
  EXPECT_TRUE(got.meta().T_base_lidar.linear().isApprox(
      Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix(), 1e-12));
  EXPECT_NEAR(got.meta().T_base_imu.translation().z(), 0.5, 1e-15);
}

std::string copy_bytes(const std::string& from, const std::string& to, std::size_t keep) {
  std::string bytes = test::read_text(from);
  bytes.resize(std::min(bytes.size(), keep));
  std::ofstream(to, std::ios::binary) << bytes;
  return bytes;
}

TEST_F(ImportCliTest, ATruncatedBagFailsNamingFileAndOffset) {
  const std::string whole = bag("bz2", "pcd", 6);
  const std::size_t size = fs::file_size(whole);
  for (const std::size_t keep : {std::size_t{10}, std::size_t{100}, std::size_t{5000}, size / 2, size - 10}) {
    SCOPED_TRACE(keep);
    const std::string cut = dir_ + "/cut.bag";
    copy_bytes(whole, cut, keep);
    const test::RunResult r = import(cut, dir_ + "/imported_cut_bag");
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_NE(r.err.find(cut + ": offset "), std::string::npos) << r.err;
  }
}

TEST_F(ImportCliTest, ACorruptChunkFailsNamingItsOffset) {
  for (const char* compression : {"bz2", "lz4"}) {
    const std::string whole = bag(compression, "pcd", 6);
    std::string bytes = test::read_text(whole);
    // The first chunk's data starts after the bag header record (4096 bytes padded) and the chunk header.
    for (std::size_t i = 5000; i < 5400; ++i) bytes[i] = static_cast<char>(bytes[i] ^ 0x5a);
    const std::string bad = dir_ + "/corrupt_" + compression + ".bag";
    std::ofstream(bad, std::ios::binary) << bytes;
    const test::RunResult r = import(bad, dir_ + "/imported_corrupt");
    EXPECT_EQ(r.exit_code, 1) << compression;
    EXPECT_NE(r.err.find(bad + ": offset "), std::string::npos) << r.err;
  }
}

TEST_F(ImportCliTest, AnotherMessageVersionIsRefusedNamingTheTopic) {
  std::string bytes = test::read_text(bag("none", "pcd", 6));
  const std::string md5 = io::kRosPointCloud2Md5;
  for (std::size_t at = bytes.find(md5); at != std::string::npos; at = bytes.find(md5, at)) {
    bytes.replace(at, md5.size(), std::string(md5.size(), '0'));
  }
  const std::string bad = dir_ + "/other_md5.bag";
  std::ofstream(bad, std::ios::binary) << bytes;
  const test::RunResult r = import(bad, dir_ + "/imported_md5");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find(bad + ": topic /points: md5sum 0000"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("from its first message) differs from the known " + md5), std::string::npos) << r.err;
}

TEST_F(ImportCliTest, DriverLayoutsVelodyneAndOuster) {
  const io::FrameDumpReader want(dump());
  // velodyne_pointcloud's PointXYZIRT: everything as the dump holds it.
  const std::string velodyne = dir_ + "/imported_velodyne";
  test::RunResult r = import(bag("none", "velodyne", 3), velodyne);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  expect_same_frames(io::FrameDumpReader(velodyne), want, 3);
  // ouster_ros's point: `t` in integer nanoseconds, reflectivity and ambient beside intensity, and a
  // NaN point after every 7th, which the import drops.
  const std::string ouster = dir_ + "/imported_ouster";
  r = import(bag("none", "ouster", 3), ouster, "--json");
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

TEST_F(ImportCliTest, WithoutATimeFieldTimesComeFromTheAzimuth) {
  const io::FrameDumpReader want(dump());
  const std::string out = dir_ + "/imported_notime";
  const test::RunResult r = import(bag("none", "notime", 2), out);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("no per-point time field"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("synthesised from the azimuth"), std::string::npos) << r.err;
  const io::FrameDumpReader got(out);
  for (std::size_t i = 0; i < 2; ++i) {
    const PointCloud a = got.frame(i), b = want.frame(i);
    ASSERT_EQ(a.size(), b.size());
    // The simulated LiDAR turns counter-clockwise from its first column at the stamp: the times are
    // the simulated ones, counted from the first point's column.
    for (std::size_t k = 0; k < a.size(); ++k) ASSERT_NEAR(a.times[k], b.times[k] - b.times[0], 2e-6) << i << ' ' << k;
  }
}

TEST_F(ImportCliTest, WithoutTfStaticTheMountingMustBeGiven) {
  const std::string path = bag("none", "pcd", 2, "--no-tf-static");
  const std::string out = dir_ + "/imported_no_tf";
  test::RunResult r = import(path, out);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find(path + ": /tf_static has no transform from base_link to 'lidar'"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("--T-base-lidar x y z roll pitch yaw"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(out));
  r = import(path, out, "--T-base-lidar 0.1 0 1.2 0 0 0 --T-base-imu 0 0 0 0 0 0 --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(Json::parse(r.out)["T_base_lidar_from"], "--T-base-lidar");
  EXPECT_TRUE(io::FrameDumpReader(out).meta().T_base_lidar.translation().isApprox(Eigen::Vector3d(0.1, 0, 1.2)));
}

TEST_F(ImportCliTest, NeverWritesOverTheUsersFiles) {
  const std::string path = bag("none", "pcd", 2);
  const std::string mine = dir_ + "/my_notes";
  fs::remove_all(mine);
  fs::create_directories(mine);
  std::ofstream(mine + "/notes.txt") << "mine";
  test::RunResult r = run_cli("import '" + path + "' -o '" + mine + "'");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find(mine), std::string::npos) << r.err;
  EXPECT_EQ(test::read_text(mine + "/notes.txt"), "mine");
  EXPECT_FALSE(fs::exists(mine + "/meta.json"));
  const std::string file = dir_ + "/a_file";
  std::ofstream(file) << "mine";
  r = run_cli("import '" + path + "' -o '" + file + "'");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_EQ(test::read_text(file), "mine");
}

TEST_F(ImportCliTest, WheelAnglesFromJointState) {
  const io::FrameDumpReader want(dump());
  const std::string path = bag("lz4", "pcd", 3, "--wheels");
  const std::string out = dir_ + "/imported_wheels";
  test::RunResult r = import(path, out, "--wheels /joint_states");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("--wheels needs --wheel-joints LEFT RIGHT"), std::string::npos) << r.err;
  r = import(path, out, "--wheels /joint_states --wheel-joints wheel_left wheel_middle");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("/joint_states message 0"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("no joint 'wheel_middle' (--wheel-joints)"), std::string::npos) << r.err;
  r = import(path, out, "--wheels /joint_states --wheel-joints wheel_left wheel_right --json");
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
TEST_F(ImportCliTest, HybridLioOnTheImportedDumpFollowsTheOriginal) {
  constexpr int kFrames = 20;
  const std::string out = dir_ + "/imported_lio";
  const test::RunResult imported = import(bag("lz4", "pcd", kFrames), out);
  ASSERT_EQ(imported.exit_code, 0) << imported.err;
  // A bag has no ground truth; with the original's both runs start at the same pose.
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
