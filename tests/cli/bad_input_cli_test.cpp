// SPDX-License-Identifier: BSD-3-Clause
// Hostile input to the `plumb` subcommands: every case must end in a non-zero exit with a message
// naming the input (file and line, or the option), never in a crash, a hang or numbers that look
// valid. Exit codes: 1 unusable input, 3 the job ran but failed, >= 100 usage errors (main.cpp).

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <unistd.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "cli_runner.hpp"
#include "plumb/core/lie.hpp"
#include "plumb/core/point_cloud.hpp"
#include "plumb/core/pose2.hpp"
#include "plumb/io/cloud_io.hpp"
#include "plumb/io/trajectory.hpp"
#include "scan2d/scan_sim.hpp"
#include "test_data.hpp"
#include "test_util.hpp"

namespace plumb {
namespace {

using test::CliTest;
using test::RunResult;
using test::run_cli;

std::string quote(const std::string& s) { return "'" + s + "'"; }

bool contains(const std::string& text, const std::string& what) { return text.find(what) != std::string::npos; }

/// Writes the lines of a TUM file (no header), so a test knows each pose's line number (1-based).
std::string write_lines(const std::string& name, const std::vector<std::string>& lines) {
  const std::string path = test::temp_path(name);
  std::ofstream out(path);
  for (const std::string& line : lines) out << line << '\n';
  return path;
}

std::vector<std::string> tum_lines(const Trajectory& t) {
  std::vector<std::string> lines;
  for (std::size_t i = 0; i < t.size(); ++i) {
    const Vector3d p = t.poses[i].translation();
    const Eigen::Quaterniond q(t.poses[i].linear());
    char buffer[256];
    std::snprintf(buffer, sizeof(buffer), "%.9f %.9f %.9f %.9f %.12f %.12f %.12f %.12f", t.stamps[i], p.x(), p.y(),
                  p.z(), q.x(), q.y(), q.z(), q.w());
    lines.emplace_back(buffer);
  }
  return lines;
}

/// The reference the eval tests compare against, one file per test process: ctest runs the tests
/// of this binary in parallel, and one process rewriting it while another read it made the reader
/// see an empty file.
std::string reference_file() {
  struct File {
    std::string path = write_lines("bad_input_ref_" + std::to_string(::getpid()) + ".tum",
                                   tum_lines(test::circle_trajectory(200)));
    ~File() { std::remove(path.c_str()); }
  };
  static const File file;
  return file.path;
}

// ---- eval: trajectories that would give numbers that look valid --------------------------------

TEST_F(CliTest, EvalStampsInMillisecondsAgainstSecondsFailNamingBothCounts) {
  const std::string est = write_lines("bad_input_est_ms.tum", tum_lines(test::circle_trajectory(200, 1000.0)));
  for (const char* format : {"", " --json"}) {
    const RunResult r = run_cli("eval " + quote(est) + ' ' + quote(reference_file()) + format);
    EXPECT_EQ(r.exit_code, 1) << r.err;
    EXPECT_TRUE(contains(r.err, est)) << r.err;
    EXPECT_TRUE(contains(r.err, "only 0 pose pairs")) << r.err;
    EXPECT_TRUE(contains(r.err, "the 200 poses")) << r.err;
    EXPECT_TRUE(r.out.empty()) << r.out;
  }
}

TEST_F(CliTest, EvalPartialTimeOverlapBelowTheFractionFailsUnlessRelaxed) {
  // Only the last 40 of 200 estimate stamps fall in the reference's time range.
  Trajectory late = test::circle_trajectory(200);
  for (double& s : late.stamps) s += 16.0;
  const std::string est = write_lines("bad_input_est_late.tum", tum_lines(late));
  const RunResult r = run_cli("eval " + quote(est) + ' ' + quote(reference_file()));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_TRUE(contains(r.err, "only 40 pose pairs")) << r.err;
  const RunResult relaxed =
      run_cli("eval " + quote(est) + ' ' + quote(reference_file()) + " --min-pair-fraction 0.1 --json");
  EXPECT_EQ(relaxed.exit_code, 0) << relaxed.err;
}

TEST_F(CliTest, EvalUnorderedStampsFailNamingFileAndLine) {
  std::vector<std::string> lines = tum_lines(test::circle_trajectory(50));
  lines.insert(lines.begin(), "# stamp tx ty tz qx qy qz qw");
  std::swap(lines[10], lines[30]);  // line 11 now holds a later stamp than line 12
  const std::string est = write_lines("bad_input_unordered.tum", lines);
  const RunResult r = run_cli("eval " + quote(est) + ' ' + quote(reference_file()));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_TRUE(contains(r.err, est + ":12:")) << r.err;
  EXPECT_TRUE(contains(r.err, "strictly increase")) << r.err;
  // A repeated stamp is refused as well.
  std::vector<std::string> repeated = tum_lines(test::circle_trajectory(5));
  repeated.push_back(repeated.back());
  const std::string dup = write_lines("bad_input_repeated.tum", repeated);
  const RunResult d = run_cli("eval " + quote(dup) + ' ' + quote(reference_file()));
  EXPECT_EQ(d.exit_code, 1);
  EXPECT_TRUE(contains(d.err, dup + ":6:")) << d.err;
}

TEST_F(CliTest, EvalKittiTimesFileOutOfOrderFailsNamingFileAndLine) {
  const std::string poses = test::temp_path("bad_input_poses.kitti");
  const std::string times = write_lines("bad_input_times.txt", {"0.0", "0.1", "0.3", "0.2"});
  Trajectory t = test::circle_trajectory(4);
  t.stamps.clear();
  io::write_kitti(t, poses);
  const RunResult r = run_cli("eval " + quote(poses) + ' ' + quote(poses) + " --format kitti --est-times " +
                              quote(times) + " --ref-times " + quote(times));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_TRUE(contains(r.err, times + ":4:")) << r.err;
}

TEST_F(CliTest, EvalHugeOrNonFiniteCoordinatesFailNamingFileAndLine) {
  for (const char* value : {"1e300", "-3e9", "nan", "inf"}) {
    std::vector<std::string> lines = tum_lines(test::circle_trajectory(20));
    lines[7] = std::to_string(100.7) + " " + value + " 0 0 0 0 0 1";
    const std::string est = write_lines("bad_input_huge.tum", lines);
    const RunResult r = run_cli("eval " + quote(est) + ' ' + quote(reference_file()) + " --json");
    EXPECT_EQ(r.exit_code, 1) << value;
    EXPECT_TRUE(contains(r.err, est + ":8:")) << value << ": " << r.err;
    EXPECT_FALSE(contains(r.out, "null")) << r.out;
  }
}

TEST_F(CliTest, EvalDegenerateAlignmentFails) {
  // Three poses on a straight line: --align se3 / sim3 cannot fix the rotation about the line.
  Trajectory line;
  for (int i = 0; i < 3; ++i) line.push_back(100.0 + 0.1 * i, se3::make(Matrix3d::Identity(), Vector3d(i, 0, 0)));
  const std::string path = write_lines("bad_input_line.tum", tum_lines(line));
  for (const char* align : {"se3", "sim3"}) {
    const RunResult r = run_cli("eval " + quote(path) + ' ' + quote(path) + " --align " + align);
    EXPECT_EQ(r.exit_code, 1) << align;
    EXPECT_TRUE(contains(r.err, std::string("--align ") + align)) << r.err;
    EXPECT_TRUE(contains(r.err, path)) << r.err;
  }
  const RunResult none = run_cli("eval " + quote(path) + ' ' + quote(path) + " --align none --json");
  EXPECT_EQ(none.exit_code, 0) << none.err;
  // Two poses are too few for any alignment (and any statistics).
  line.poses.pop_back();
  line.stamps.pop_back();
  const std::string two = write_lines("bad_input_two.tum", tum_lines(line));
  const RunResult r = run_cli("eval " + quote(two) + ' ' + quote(two) + " --align none");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_TRUE(contains(r.err, "only 2 pose pairs")) << r.err;
}

TEST_F(CliTest, EvalDirectoryInsteadOfFileSaysSo) {
  const std::string dir = test::temp_path("bad_input_dir");
  std::filesystem::create_directories(dir);
  const RunResult r = run_cli("eval " + quote(dir) + ' ' + quote(reference_file()));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_TRUE(contains(r.err, dir + ": is a directory")) << r.err;
}

TEST_F(CliTest, EvalNumericOptionsRejectNanInfAndNonsense) {
  const std::string files = quote(reference_file()) + ' ' + quote(reference_file());
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"--rpe-delta nan", "--rpe-delta"},       {"--rpe-delta inf", "--rpe-delta"},
      {"--rpe-delta 1.5", "--rpe-delta"},       {"--max-time-diff nan", "--max-time-diff"},
      {"--max-time-diff inf", "--max-time-diff"}, {"--max-time-diff -1", "--max-time-diff"},
      {"--time-offset nan", "--time-offset"},   {"--drift-at-time inf", "--drift-at-time"},
      {"--min-pair-fraction 2", "--min-pair-fraction"}, {"--drift-at 5000", "--drift-at"}};
  for (const auto& [args, option] : cases) {
    const RunResult r = run_cli("eval " + files + ' ' + args);
    EXPECT_NE(r.exit_code, 0) << args;
    EXPECT_GT(r.exit_code, 0) << args;
    EXPECT_TRUE(contains(r.err, option)) << args << ": " << r.err;
    EXPECT_FALSE(contains(r.err, "179769")) << args << ": " << r.err;  // DBL_MAX printed in full
  }
}

// ---- scan2d: CARMEN logs ----------------------------------------------------------------------

/// A robot creeping along x in the test room, one ODOM and one FLASER line per 0.1 s (the ODOM of
/// step k on line 2 + 2k, its FLASER on line 3 + 2k). `backwards`: the FLASER of that step gets a
/// stamp 0.15 s before the previous one. `blind`: every range is 0 (no valid beam).
std::string write_carmen(const std::string& name, int steps, int backwards, bool blind) {
  const std::string path = test::temp_path(name);
  std::ofstream log(path);
  log.precision(17);
  log << "# synthetic log for plumb scan2d\n";
  const auto world = test::room_world();
  for (int k = 0; k < steps; ++k) {
    const double t = 100.0 + 0.1 * k;
    const Pose2 pose{0.3 + 0.02 * k, 0.2, 0.1};
    log << "ODOM " << pose.x << ' ' << pose.y << ' ' << pose.theta << " 0.2 0 0 " << t << " sim " << t << '\n';
    const LaserScan scan = test::cast_scan(world, pose, 181, test::kPi, 30.0);
    const double stamp = k == backwards ? t - 0.25 : t + 0.001;
    log << "FLASER " << scan.ranges.size();
    for (float r : scan.ranges) log << ' ' << (blind ? 0.0f : r);
    log << ' ' << pose.x << ' ' << pose.y << ' ' << pose.theta << ' ' << pose.x << ' ' << pose.y << ' '
        << pose.theta << ' ' << stamp << " sim " << stamp << '\n';
  }
  return path;
}

TEST_F(CliTest, Scan2dDropsScansWhoseStampGoesBackWithAWarning) {
  const std::string log = write_carmen("bad_input_backwards.log", 12, 6, false);
  const std::string out = test::temp_path("bad_input_backwards.tum");
  const RunResult r = run_cli("scan2d " + quote(log) + " -o " + quote(out) + " --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(contains(r.err, "warning: " + log + ":15:")) << r.err;  // FLASER of step 6
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j.at("dropped_scans"), 1);
  EXPECT_EQ(j.at("scans"), 11);
  const Trajectory t = io::read_tum(out);  // the reader refuses stamps that do not increase
  EXPECT_EQ(t.size(), 11u);
}

TEST_F(CliTest, Scan2dWhereNoScanMatchesExitsThree) {
  const std::string log = write_carmen("bad_input_blind.log", 6, -1, true);
  const std::string out = test::temp_path("bad_input_blind.tum");
  std::remove(out.c_str());
  const RunResult r = run_cli("scan2d " + quote(log) + " -o " + quote(out) + " --json");
  EXPECT_EQ(r.exit_code, 3) << r.err;
  EXPECT_TRUE(contains(r.err, "plumb: failed: " + log)) << r.err;
  EXPECT_TRUE(test::file_exists(out));  // the odometry-only trajectory is still written
  EXPECT_EQ(nlohmann::json::parse(r.out).at("matched"), 0);
}

TEST_F(CliTest, Scan2dLaserPoseRejectsNanInfAndDegrees) {
  const std::string log = write_carmen("bad_input_pose.log", 3, -1, false);
  const std::string out = test::temp_path("bad_input_pose.tum");
  for (const char* pose : {"nan 0 0", "0 inf 0", "1e300 0 0", "0 0 90"}) {
    std::remove(out.c_str());
    const RunResult r = run_cli("scan2d " + quote(log) + " -o " + quote(out) + " --laser-pose " + pose);
    EXPECT_NE(r.exit_code, 0) << pose;
    EXPECT_GT(r.exit_code, 0) << pose;
    EXPECT_TRUE(contains(r.err, "--laser-pose")) << pose << ": " << r.err;
    EXPECT_FALSE(test::file_exists(out)) << pose;
  }
}

// ---- register, segment, ifc2cloud, calibrate, make-demo-building: options and files ------------

std::string small_cloud() {
  static const std::string path = [] {
    PointCloud cloud;
    for (int i = 0; i < 20; ++i) {
      for (int j = 0; j < 20; ++j) cloud.points.emplace_back(0.1f * i, 0.1f * j, 0.0f);
    }
    const std::string p = test::temp_path("bad_input_cloud.pcd");
    io::write_cloud(p, cloud);
    return p;
  }();
  return path;
}

TEST_F(CliTest, RegisterFailedStatusExitsThreeAndSaysWhy) {
  PointCloud two;
  two.points = {Vector3f(0, 0, 0), Vector3f(1, 0, 0)};
  const std::string path = test::temp_path("bad_input_two.pcd");
  io::write_cloud(path, two);
  const RunResult r = run_cli("register " + quote(path) + ' ' + quote(path) + " --json");
  EXPECT_EQ(r.exit_code, 3) << r.err;
  EXPECT_TRUE(contains(r.err, "plumb: failed: " + path)) << r.err;
  EXPECT_TRUE(contains(r.err, "insufficient_data")) << r.err;
  EXPECT_EQ(nlohmann::json::parse(r.out).at("status"), "insufficient_data");  // the result, for diagnosis
}

// Errors raised deep in the library (a voxel grid whose keys would overflow, a cloud without
// extent) cannot know the file their data came from; the CLI names the command's inputs for them.
TEST_F(CliTest, LibraryErrorsNameTheCommandsInputs) {
  PointCloud same;
  same.points = {Vector3f(1, 2, 3), Vector3f(1, 2, 3)};
  const std::string point = test::temp_path("bad_input_point.pcd");
  io::write_cloud(point, same);
  RunResult r = run_cli("register " + quote(small_cloud()) + ' ' + quote(point));
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_TRUE(contains(r.err, "plumb: error: " + point + ": the target has no extent")) << r.err;

  PointCloud wide;
  for (int i = 0; i < 50; ++i) {
    const float f = static_cast<float>(i);
    wide.points.emplace_back(400.0f * f, 0.0f, 0.01f * static_cast<float>(i % 7));
    wide.points.emplace_back(0.0f, 400.0f * f, 0.0f);
  }
  const std::string wide_path = test::temp_path("bad_input_wide.pcd");
  io::write_cloud(wide_path, wide);
  r = run_cli("register " + quote(wide_path) + ' ' + quote(small_cloud()) + " --voxel 1e-7");
  EXPECT_EQ(r.exit_code, 1) << r.err;
  // The library's message, prefixed with both inputs (each once), not the bare "voxel_grid: ...".
  EXPECT_TRUE(contains(r.err, "plumb: error: " + wide_path + ", " + small_cloud() + ": voxel_grid:")) << r.err;
  r = run_cli("register " + quote(wide_path) + ' ' + quote(wide_path) + " --voxel 1e-7");
  EXPECT_TRUE(contains(r.err, "plumb: error: " + wide_path + ": voxel_grid:")) << r.err;
}

TEST_F(CliTest, CloudCommandOptionsRejectNanInf) {
  const std::string cloud = quote(small_cloud());
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"register " + cloud + ' ' + cloud + " --voxel nan", "--voxel"},
      {"register " + cloud + ' ' + cloud + " --voxel inf", "--voxel"},
      {"register " + cloud + ' ' + cloud + " --voxel -0.1", "--voxel"},
      {"segment " + cloud + " --sensor-height nan", "--sensor-height"},
      {"segment " + cloud + " --sensor-height inf", "--sensor-height"},
      {"segment " + cloud + " --sensor-height 0", "--sensor-height"}};
  for (const auto& [args, option] : cases) {
    const RunResult r = run_cli(args);
    EXPECT_NE(r.exit_code, 0) << args;
    EXPECT_GT(r.exit_code, 0) << args;
    EXPECT_TRUE(contains(r.err, option)) << args << ": " << r.err;
    EXPECT_FALSE(contains(r.err, "179769")) << args << ": " << r.err;
  }
}

TEST_F(CliTest, IfcAndBuildingOptionsRejectNanInfWithShortMessages) {
  const std::string model = quote(test::source_dir() + "/examples/data/demo_office.ifc");
  const std::string out = quote(test::temp_path("bad_input_out.ply"));
  const std::string ifc = quote(test::temp_path("bad_input_building.ifc"));
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"ifc2cloud " + model + " -o " + out + " --spacing inf", "--spacing"},
      {"ifc2cloud " + model + " -o " + out + " --spacing nan", "--spacing"},
      {"ifc2cloud " + model + " -o " + out + " --spacing -1", "--spacing"},
      {"make-demo-building -o " + ifc + " --length nan", "--length"},
      {"make-demo-building -o " + ifc + " --width inf", "--width"},
      {"make-demo-building -o " + ifc + " --storey-height nan", "--storey-height"},
      {"make-demo-building -o " + ifc + " --corridor-width -2", "--corridor-width"},
      {"make-demo-building -o " + ifc + " --door-width nan", "--door-width"},
      {"make-demo-building -o " + ifc + " --entrance-width inf", "--entrance-width"},
      {"make-demo-building -o " + ifc + " --column-size nan", "--column-size"},
      {"make-demo-building -o " + ifc + " --storeys 0", "--storeys"},
      {"make-demo-building -o " + ifc + " --rooms -4", "--rooms"}};
  for (const auto& [args, option] : cases) {
    const RunResult r = run_cli(args);
    EXPECT_NE(r.exit_code, 0) << args;
    EXPECT_GT(r.exit_code, 0) << args;
    EXPECT_TRUE(contains(r.err, option)) << args << ": " << r.err;
    EXPECT_LT(r.err.size(), 300u) << args << ": " << r.err;  // sane numbers, not 309 digits
  }
}

TEST_F(CliTest, CalibrateOptionsRejectNanInf) {
  const std::string tuples = quote(test::temp_path("bad_input_none.tuple"));
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"calibrate " + tuples + " --outlier-quantile nan", "--outlier-quantile"},
      {"calibrate " + tuples + " --outlier-iterations 1e9", "--outlier-iterations"},
      {"calibrate --log a.log --wheels b.csv --ticks-per-rev inf", "--ticks-per-rev"},
      {"calibrate --log a.log --wheels b.csv --nominal 0.05 0.05 0.4 nan 0 0", "--nominal"},
      {"calibrate --log a.log --wheels b.csv --nominal 0.05 -0.05 0.4 0 0 0", "--nominal"}};
  for (const auto& [args, option] : cases) {
    const RunResult r = run_cli(args);
    EXPECT_NE(r.exit_code, 0) << args;
    EXPECT_GT(r.exit_code, 0) << args;
    EXPECT_TRUE(contains(r.err, option)) << args << ": " << r.err;
  }
}

TEST_F(CliTest, DirectoriesGivenAsFilesAreNamedAsSuch) {
  const std::string dir = test::temp_path("bad_input_dir");
  std::filesystem::create_directories(dir);
  for (const std::string& args :
       {"ifcinfo " + quote(dir), "ifc2cloud " + quote(dir) + " -o " + quote(test::temp_path("bad_input_d.ply")),
        "calibrate " + quote(dir), "calibrate --log " + quote(dir) + " --wheels " + quote(dir),
        "eval " + quote(dir) + ' ' + quote(dir) + " --format kitti"}) {
    const RunResult r = run_cli(args);
    EXPECT_EQ(r.exit_code, 1) << args;
    EXPECT_TRUE(contains(r.err, dir + ": is a directory")) << args << ": " << r.err;
  }
  // Arguments checked by CLI11 as existing files say it too (a usage error).
  const RunResult r = run_cli("segment " + quote(dir));
  EXPECT_GE(r.exit_code, 100);
  EXPECT_TRUE(contains(r.err, "directory")) << r.err;
}

// A LiDAR model file whose column count is not a whole number in range is refused by name: a
// fractional or boolean value used to be truncated, and 1e10 converted to int is undefined.
TEST_F(CliTest, SimulateLidarModelColumnsMustBeAWholeNumberInRange) {
  const std::string model = test::source_dir() + "/examples/data/demo_office.ifc";
  for (const char* columns : {"2.5", "true", "1e10", "0", "100001"}) {
    const std::string json = write_lines("bad_input_lidar.json",
                                         {std::string("{\"elevations_deg\": [-15, 0, 15], \"columns\": ") + columns + "}"});
    const std::string out = test::temp_path("bad_input_lidar_dump");
    std::filesystem::remove_all(out);
    const RunResult r = run_cli("simulate " + quote(model) + " -o " + quote(out) + " --lidar " + quote(json));
    EXPECT_EQ(r.exit_code, 1) << columns << ": " << r.err;
    EXPECT_TRUE(contains(r.err, json) && contains(r.err, "columns")) << columns << ": " << r.err;
  }
}

}  // namespace
}  // namespace plumb
