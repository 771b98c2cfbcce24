// SPDX-License-Identifier: BSD-3-Clause
// What `plumb run`, `lio`, `simulate` and `demo` do with a user's files and with bad input: outputs
// are checked before the work, a directory holding files plumb did not write is refused unless
// --overwrite, a set is replaced as a whole, a failure leaves the previous set as it was, a frame
// failing mid-run still writes what was computed (marked partial), and data problems (odometry or
// ground truth not covering the frames, a non-finite extrinsic, absurd option values) are named.
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <fstream>
#include <sstream>
#include <string>
#include <system_error>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "cli_runner.hpp"
#include "plumb/io/frame_dump.hpp"
#include "plumb/io/pcd.hpp"
#include "test_data.hpp"

namespace plumb {
namespace {

namespace fs = std::filesystem;
using test::CliTest;
using test::run_cli;
using Json = nlohmann::json;

std::string office_ifc() { return test::source_dir() + "/examples/data/demo_office.ifc"; }

std::string q(const std::string& s) { return "'" + s + "'"; }

std::string unique(const std::string& name) { return test::temp_path("outsafe_" + name + "_" + std::to_string(::getpid())); }

/// A short dump in the demo office (16-line LiDAR), made once per test process; tests copy it.
const std::string& base_dump() {
  struct Removed {
    std::string dir;
    ~Removed() {
      std::error_code ec;
      if (!dir.empty()) fs::remove_all(dir, ec);
    }
  };
  static Removed made;
  std::string& dir = made.dir;
  if (dir.empty()) {
    dir = unique("base_dump");
    fs::remove_all(dir);
    const test::RunResult r =
        run_cli("simulate " + q(office_ifc()) + " -o " + q(dir) + " --lidar vlp16 --length 2 --seed 4");
    EXPECT_EQ(r.exit_code, 0) << r.err;
  }
  return dir;
}

std::string copy_dump(const std::string& name) {
  const std::string out = unique(name);
  fs::remove_all(out);
  fs::copy(base_dump(), out, fs::copy_options::recursive);
  return out;
}

/// The LiDAR files the tests wrote, removed at exit.
std::vector<std::string>& lidar_files() {
  struct Removed {
    std::vector<std::string> paths;
    ~Removed() {
      std::error_code ec;
      for (const std::string& p : paths) fs::remove(p, ec);
    }
  };
  static Removed made;
  return made.paths;
}

/// A coarse LiDAR (4 rows) for quick simulations.
std::string tiny_lidar(const std::string& name, const std::string& rate_hz = "10", const std::string& columns = "60") {
  const std::string path = unique(name) + ".json";
  std::ofstream(path) << R"({"name": "tiny", "elevations_deg": [-15, -7, 0, 7], "columns": )" << columns
                      << ", \"rate_hz\": " << rate_hz << "}";
  lidar_files().push_back(path);
  return path;
}

std::vector<std::string> lines_of(const std::string& path) {
  std::ifstream in(path);
  std::vector<std::string> out;
  for (std::string line; std::getline(in, line);) out.push_back(line);
  return out;
}

void write_file_lines(const std::string& path, const std::vector<std::string>& lines) {
  std::ofstream out(path);
  for (const std::string& l : lines) out << l << '\n';
}

std::size_t count_data_lines(const std::string& path) {
  std::size_t n = 0;
  for (const std::string& l : lines_of(path)) n += (!l.empty() && l[0] != '#') ? 1 : 0;
  return n;
}

std::size_t count_entries(const std::string& dir) {
  std::size_t n = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir)) ++n;
  return n;
}

bool has_staging_leftover(const std::string& dir) {
  for (const auto& e : fs::directory_iterator(dir)) {
    if (e.path().filename().string().rfind(".plumb-staging", 0) == 0) return true;
  }
  return false;
}

std::string run_args(const std::string& dump, const std::string& out, const std::string& extra = "") {
  return "run " + q(dump) + " --bim " + q(office_ifc()) + " -o " + q(out) + " --gt-start " + extra;
}

double seconds_of(const std::function<void()>& f) {
  const auto t0 = std::chrono::steady_clock::now();
  f();
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

TEST_F(CliTest, UnwritableOutputFailsBeforeAnyFrameIsProcessed) {
  const std::string dump = base_dump();
  // A regular file where the output directory (or its parent) should be: nothing can be created there.
  const std::string blocker = unique("blocker");
  std::ofstream(blocker) << "a user's file\n";
  for (const std::string& out : {blocker, blocker + "/out"}) {
    test::RunResult r;
    // The whole dump would take many seconds; the check comes before the model is even read.
    EXPECT_LT(seconds_of([&] { r = run_cli(run_args(dump, out)); }), 5.0);
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_NE(r.err.find(out), std::string::npos) << r.err;
    EXPECT_LT(seconds_of([&] { r = run_cli("lio " + q(dump) + " --mode loam -o " + q(out)); }), 5.0);
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_NE(r.err.find(out), std::string::npos) << r.err;
    EXPECT_LT(seconds_of([&] { r = run_cli("simulate " + q(office_ifc()) + " -o " + q(out) + " --length 2"); }), 5.0);
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_NE(r.err.find(out), std::string::npos) << r.err;
    EXPECT_LT(seconds_of([&] { r = run_cli("demo -o " + q(out) + " --length 2"); }), 5.0);
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_NE(r.err.find(out), std::string::npos) << r.err;
  }
  EXPECT_EQ(test::read_text(blocker), "a user's file\n");
  fs::remove(blocker);
}

TEST_F(CliTest, ForeignFilesAreRefusedWithoutOverwriteAndLeftUntouched) {
  const std::string dump = base_dump();
  const std::string out = unique("foreign_out");
  fs::remove_all(out);
  fs::create_directories(out);
  std::ofstream(out + "/report.json") << "{\"mine\": true}\n";
  std::ofstream(out + "/notes.txt") << "field notes\n";
  for (const std::string& args :
       {run_args(dump, out, "--max-frames 3"), "lio " + q(dump) + " --mode loam --max-frames 3 -o " + q(out),
        "simulate " + q(office_ifc()) + " -o " + q(out) + " --length 2", "demo -o " + q(out) + " --length 2"}) {
    const test::RunResult r = run_cli(args);
    EXPECT_EQ(r.exit_code, 1) << args;
    EXPECT_NE(r.err.find(out), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("plumb did not write"), std::string::npos) << r.err;
    EXPECT_EQ(test::read_text(out + "/report.json"), "{\"mine\": true}\n") << args;
    EXPECT_EQ(test::read_text(out + "/notes.txt"), "field notes\n") << args;
    EXPECT_EQ(count_entries(out), 2u) << args;
  }
  // A user's odom.csv (no meta.json): simulate refuses it too.
  const std::string dump_out = unique("foreign_dump");
  fs::remove_all(dump_out);
  fs::create_directories(dump_out);
  std::ofstream(dump_out + "/odom.csv") << "stamp,x,y,theta\n0,0,0,0\n";
  test::RunResult r = run_cli("simulate " + q(office_ifc()) + " -o " + q(dump_out) + " --length 2");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("odom.csv"), std::string::npos) << r.err;
  EXPECT_EQ(test::read_text(dump_out + "/odom.csv"), "stamp,x,y,theta\n0,0,0,0\n");
  // --overwrite replaces plumb's own file names and keeps the others.
  r = run_cli(run_args(dump, out, "--max-frames 3 --overwrite"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(Json::parse(test::read_text(out + "/report.json")).at("frames"), 3);
  EXPECT_EQ(test::read_text(out + "/notes.txt"), "field notes\n");
  EXPECT_FALSE(has_staging_leftover(out));
  // demo takes --overwrite too: its model, dump and run appear beside the user's file.
  const std::string demo_out = unique("foreign_demo");
  fs::remove_all(demo_out);
  fs::create_directories(demo_out);
  std::ofstream(demo_out + "/notes.txt") << "field notes\n";
  r = run_cli("demo -o " + q(demo_out) + " --length 2 --surveyed-start --overwrite");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(fs::is_regular_file(demo_out + "/run/report.json"));
  EXPECT_EQ(test::read_text(demo_out + "/notes.txt"), "field notes\n");
  fs::remove_all(demo_out);
  // Its own output is plumb's: `run` replaces it without --overwrite.
  r = run_cli(run_args(dump, out + "_own", "--max-frames 2"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = run_cli(run_args(dump, out + "_own", "--max-frames 3"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(count_data_lines(out + "_own/bim.tum"), 3u);
  fs::remove_all(out);
  fs::remove_all(out + "_own");
  fs::remove_all(dump_out);
}

TEST_F(CliTest, OverwriteReplacesTheWholeDumpWithoutStaleFrames) {
  const std::string dir = unique("overwrite_dump");
  fs::remove_all(dir);
  const std::string lidar = tiny_lidar("overwrite_lidar");
  test::RunResult r = run_cli("simulate " + q(office_ifc()) + " -o " + q(dir) + " --lidar " + q(lidar) + " --length 4");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::size_t long_frames = io::FrameDumpReader(dir).num_frames();
  // Without --overwrite an earlier dump is kept.
  r = run_cli("simulate " + q(office_ifc()) + " -o " + q(dir) + " --lidar " + q(lidar) + " --length 2");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("--overwrite"), std::string::npos) << r.err;
  EXPECT_EQ(io::FrameDumpReader(dir).num_frames(), long_frames);
  r = run_cli("simulate " + q(office_ifc()) + " -o " + q(dir) + " --lidar " + q(lidar) + " --length 2 --overwrite");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const io::FrameDumpReader dump(dir);
  ASSERT_LT(dump.num_frames(), long_frames);
  EXPECT_EQ(count_entries(dir + "/frames"), dump.num_frames());  // no orphan frame of the longer run
  EXPECT_FALSE(has_staging_leftover(dir));
  fs::remove_all(dir);
}

TEST_F(CliTest, AFailedRunLeavesThePreviousSetUntouched) {
  const std::string dump = copy_dump("failed_dump");
  const std::string out = unique("failed_out");
  fs::remove_all(out);
  ASSERT_EQ(run_cli(run_args(dump, out, "--max-frames 3")).exit_code, 0);
  std::vector<std::string> before;
  for (const char* f : {"report.json", "wheel.tum", "lidar.tum", "bim.tum", "trajectory.svg"}) {
    before.push_back(test::read_text(out + "/" + f));
  }
  const std::size_t entries = count_entries(out);
  // The first frame unreadable: nothing is computed, nothing is written.
  std::ofstream(dump + "/frames/000000.pcd", std::ios::trunc) << "not a point cloud\n";
  const test::RunResult r = run_cli(run_args(dump, out, "--max-frames 3"));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("000000.pcd"), std::string::npos) << r.err;
  std::size_t k = 0;
  for (const char* f : {"report.json", "wheel.tum", "lidar.tum", "bim.tum", "trajectory.svg"}) {
    EXPECT_EQ(test::read_text(out + "/" + f), before[k++]) << f;
  }
  EXPECT_EQ(count_entries(out), entries);
  // A new directory is not left behind either.
  EXPECT_EQ(run_cli(run_args(dump, out + "_new", "--max-frames 3")).exit_code, 1);
  EXPECT_FALSE(fs::exists(out + "_new"));
  fs::remove_all(dump);
  fs::remove_all(out);
}

TEST_F(CliTest, AMidRunFailureWritesThePartialResults) {
  const std::string dump = copy_dump("partial_dump");
  std::ofstream(dump + "/frames/000003.pcd", std::ios::trunc) << "not a point cloud\n";
  const std::string out = unique("partial_out");
  fs::remove_all(out);
  test::RunResult r = run_cli(run_args(dump, out, "--max-frames 6"));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("000003.pcd"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("partial"), std::string::npos) << r.err;
  Json j = Json::parse(test::read_text(out + "/report.json"));
  EXPECT_TRUE(j.at("partial").get<bool>());
  EXPECT_EQ(j.at("frames"), 3);
  EXPECT_EQ(j.at("frames_requested"), 6);
  EXPECT_NE(j.at("error").get<std::string>().find("000003.pcd"), std::string::npos);
  EXPECT_EQ(count_data_lines(out + "/bim.tum"), 3u);
  EXPECT_TRUE(fs::exists(out + "/trajectory.svg"));
  // With the as-built estimate and --refine: the same partial run, its deviation report, and no
  // second pass over a run that stopped.
  r = run_cli(run_args(dump, out + "_refine", "--max-frames 6 --as-built --refine"));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("000003.pcd"), std::string::npos) << r.err;
  EXPECT_EQ(count_data_lines(out + "_refine/bim.tum"), 3u);
  EXPECT_TRUE(fs::exists(out + "_refine/deviations.json"));
  EXPECT_FALSE(fs::exists(out + "_refine/bim_refined.tum"));
  fs::remove_all(out + "_refine");

  r = run_cli("lio " + q(dump) + " --mode loam --max-frames 6 -o " + q(out + "_lio"));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("000003.pcd"), std::string::npos) << r.err;
  j = Json::parse(test::read_text(out + "_lio/report.json"));
  EXPECT_TRUE(j.at("partial").get<bool>());
  EXPECT_EQ(j.at("frames"), 3);
  EXPECT_EQ(count_data_lines(out + "_lio/trajectory.tum"), 3u);
  fs::remove_all(dump);
  fs::remove_all(out);
  fs::remove_all(out + "_lio");
}

TEST_F(CliTest, OdometryAndGroundTruthNotCoveringTheFramesAreNamed) {
  const std::string dump = copy_dump("coverage_dump");
  const io::FrameDumpReader reader(dump);
  ASSERT_GE(reader.num_frames(), 8u);
  const std::vector<std::string> odom = lines_of(dump + "/odom.csv");
  auto odom_until = [&](double t_end) {
    std::vector<std::string> keep = {odom.front()};
    for (std::size_t i = 1; i < odom.size(); ++i) {
      if (std::stod(odom[i].substr(0, odom[i].find(','))) <= t_end) keep.push_back(odom[i]);
    }
    write_file_lines(dump + "/odom.csv", keep);
  };
  const std::string out = unique("coverage_out");
  fs::remove_all(out);
  // Ending at frame 4's stamp: frame 6 is two LiDAR periods beyond, an error naming it.
  odom_until(reader.stamp(4) + 0.05);
  test::RunResult r = run_cli(run_args(dump, out, "--max-frames 8"));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("odom.csv"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("frame 6 "), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(out));
  // Within one LiDAR period of the last frame: processed with a warning and a report field.
  r = run_cli(run_args(dump, out, "--max-frames 6"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("warning"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("odom.csv"), std::string::npos) << r.err;
  Json j = Json::parse(test::read_text(out + "/report.json"));
  EXPECT_EQ(j.at("odometry_clamped_frames"), 1);

  // gt.tum shorter than the frames: said on stderr and in report.json (run and lio).
  write_file_lines(dump + "/odom.csv", odom);
  std::vector<std::string> gt = lines_of(dump + "/gt.tum");
  write_file_lines(dump + "/gt.tum", std::vector<std::string>(gt.begin(), gt.begin() + 4));
  r = run_cli(run_args(dump, out, "--max-frames 6"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("gt.tum"), std::string::npos) << r.err;
  j = Json::parse(test::read_text(out + "/report.json"));
  EXPECT_EQ(j.at("ground_truth"), "too_short");
  EXPECT_FALSE(j.contains("table"));
  r = run_cli("lio " + q(dump) + " --mode loam --max-frames 6 -o " + q(out + "_lio"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("gt.tum"), std::string::npos) << r.err;
  j = Json::parse(test::read_text(out + "_lio/report.json"));
  EXPECT_EQ(j.at("ground_truth"), "too_short");
  ASSERT_FALSE(j.at("warnings").empty());
  // lio checks gt.tum's stamps against the frames, as run does.
  gt[2] = "999" + gt[2].substr(gt[2].find(' '));
  write_file_lines(dump + "/gt.tum", gt);
  r = run_cli("lio " + q(dump) + " --mode loam --max-frames 6 -o " + q(out + "_lio"));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("gt.tum"), std::string::npos) << r.err;
  fs::remove_all(dump);
  fs::remove_all(out);
  fs::remove_all(out + "_lio");
}

TEST_F(CliTest, LioStartsAtTheFirstUsableFrame) {
  const std::string dump = copy_dump("lio_empty_dump");
  io::write_pcd(dump + "/frames/000000.pcd", PointCloud{});
  const std::string out = unique("lio_empty_out");
  fs::remove_all(out);
  test::RunResult r = run_cli("lio " + q(dump) + " --mode loam --max-frames 8 -o " + q(out) + " --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const Json j = Json::parse(r.out);
  EXPECT_EQ(j.at("first_frame"), 1);
  EXPECT_EQ(j.at("frames_per_mode").at("skipped"), 1);
  EXPECT_EQ(j.at("frames_per_mode").at("init"), 1);
  EXPECT_EQ(j.at("frames_per_mode").at("loam"), 6);
  EXPECT_EQ(count_data_lines(out + "/trajectory.tum"), 7u);
  // No usable frame at all: a clear error, not a trajectory of predictions.
  for (std::size_t i = 1; i < 3; ++i) {
    char name[64];
    std::snprintf(name, sizeof(name), "/frames/%06zu.pcd", i);
    io::write_pcd(dump + name, PointCloud{});
  }
  r = run_cli("lio " + q(dump) + " --mode loam --max-frames 3 -o " + q(out));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("start the map"), std::string::npos) << r.err;
  fs::remove_all(dump);
  fs::remove_all(out);
}

// A LiDAR that sees (almost) nothing after the first frame: every later frame falls back to the
// wheel prior in `run` and to the motion prediction in `lio`. The sets are written, but the job
// failed: exit 3 with a message saying what the trajectories are. One usable frame more and it
// is a success again.
TEST_F(CliTest, AJobWhereTheLidarNeverRegisteredExitsThree) {
  const std::string dump = copy_dump("blind_dump");
  PointCloud three;
  three.points = {Vector3f(1, 0, 0), Vector3f(0, 1, 0), Vector3f(40, 40, 0)};
  for (std::size_t i = 1; i < 8; ++i) {
    char name[64];
    std::snprintf(name, sizeof(name), "/frames/%06zu.pcd", i);
    io::write_pcd(dump + name, three);
  }
  const std::string out = unique("blind_out");
  fs::remove_all(out);
  test::RunResult r = run_cli(run_args(dump, out, "--max-frames 8 --json"));
  EXPECT_EQ(r.exit_code, 3) << r.err;
  EXPECT_NE(r.err.find("plumb: failed: " + dump + ": no frame after the first was matched"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("wheel odometry"), std::string::npos) << r.err;
  EXPECT_EQ(Json::parse(r.out).at("fallbacks"), 7);
  EXPECT_EQ(count_data_lines(out + "/bim.tum"), 8u);
  r = run_cli(run_args(dump, out, "--max-frames 1 --overwrite"));
  EXPECT_EQ(r.exit_code, 0) << r.err;

  r = run_cli("lio " + q(dump) + " --mode loam --max-frames 8 --overwrite -o " + q(out) + " --json");
  EXPECT_EQ(r.exit_code, 3) << r.err;
  EXPECT_NE(r.err.find("plumb: failed: " + dump + ": no frame after the first was registered"), std::string::npos)
      << r.err;
  EXPECT_EQ(Json::parse(r.out).at("frames_per_mode").at("prediction"), 7);
  EXPECT_EQ(count_data_lines(out + "/trajectory.tum"), 8u);
  r = run_cli("lio " + q(dump) + " --mode loam --max-frames 9 --overwrite -o " + q(out));
  EXPECT_EQ(r.exit_code, 0) << r.err;
  fs::remove_all(dump);
  fs::remove_all(out);
}

TEST_F(CliTest, ANonFiniteExtrinsicOrAbsurdRateInMetaJsonIsNamed) {
  const std::string dump = copy_dump("meta_dump");
  const std::string meta = test::read_text(dump + "/meta.json");
  const std::string out = unique("meta_out");
  fs::remove_all(out);
  const std::size_t k = meta.find("\"T_base_lidar\": [");
  ASSERT_NE(k, std::string::npos);
  std::string bad = meta;
  bad.replace(k + 17, 1, "1e999");  // first entry "1" -> an infinity
  std::ofstream(dump + "/meta.json", std::ios::trunc) << bad;
  for (const std::string& args : {run_args(dump, out), "lio " + q(dump) + " --mode loam -o " + q(out)}) {
    const test::RunResult r = run_cli(args);
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_NE(r.err.find("meta.json"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("T_base_lidar"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("finite"), std::string::npos) << r.err;
  }
  bad = meta;
  const std::size_t rate = bad.find("\"rate_hz\": 10");
  ASSERT_NE(rate, std::string::npos);
  bad.replace(rate, 13, "\"rate_hz\": 1e-9");
  std::ofstream(dump + "/meta.json", std::ios::trunc) << bad;
  const test::RunResult r = run_cli(run_args(dump, out));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("rate_hz"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(out));
  fs::remove_all(dump);
}

TEST_F(CliTest, CountAndSizeOptionsHaveLimits) {
  const std::string out = unique("limits_out");
  fs::remove_all(out);
  auto simulate = [&](const std::string& extra) {
    test::RunResult r;
    EXPECT_LT(seconds_of([&] { r = run_cli("simulate " + q(office_ifc()) + " -o " + q(out) + " " + extra); }), 10.0)
        << extra;
    return r;
  };
  for (const char* extra : {"--clutter 1e9", "--clutter -1", "--length 1e9", "--length -1", "--as-built-sigma 1e9"}) {
    const test::RunResult r = simulate(extra);
    EXPECT_NE(r.exit_code, 0) << extra;
    EXPECT_FALSE(r.err.empty()) << extra;
  }
  test::RunResult r = simulate("--lidar " + q(tiny_lidar("slow_lidar")) + " --length 2");
  ASSERT_EQ(r.exit_code, 0) << r.err;  // the tiny LiDAR itself is fine
  fs::remove_all(out);
  r = simulate("--lidar " + q(tiny_lidar("rate_lidar", "1e-9")) + " --length 2");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("rate_hz"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(out + "/meta.json"));
  r = simulate("--lidar " + q(tiny_lidar("columns_lidar", "10", "1000000000")) + " --length 2");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("columns"), std::string::npos) << r.err;
  // Negative counts of run do not wrap around to huge ones.
  r = run_cli(run_args(base_dump(), out, "--max-frames -3"));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("max-frames"), std::string::npos) << r.err;
  fs::remove_all(out);
}

}  // namespace
}  // namespace plumb
