// SPDX-License-Identifier: BSD-3-Clause
// `plumb run` and `plumb demo` as a user runs them: a short simulated run in the demo office from
// the surveyed start, the three trajectories against the exact ground truth; a dump without wheel
// odometry and bad options fail with a clear message; `run --as-built` writes the deviation report
// as JSON, CSV, a floor plan SVG and a BCF archive that validates against the BCF 2.1 schemas.
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "bcf_check.hpp"
#include "cli_runner.hpp"
#include "plumb/io/frame_dump.hpp"
#include "plumb/io/trajectory.hpp"
#include "test_data.hpp"
#include "test_util.hpp"

namespace plumb {
namespace {

using test::CliTest;
using test::run_cli;
using Json = nlohmann::json;

std::string demo_model() { return test::source_dir() + "/examples/data/demo_office.ifc"; }

/// A short run in the demo office (16-line LiDAR to keep it quick), one per test process.
std::string simulate_demo_dump(const std::string& name, double length) {
  const std::string dir = test::temp_path(name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  const test::RunResult r = run_cli("simulate '" + demo_model() + "' -o '" + dir + "' --lidar vlp16 --length " +
                                    std::to_string(length) + " --seed 4");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  return dir;
}

std::size_t count_lines(const std::string& path) {
  std::ifstream in(path);
  std::size_t n = 0;
  for (std::string line; std::getline(in, line);) n += (!line.empty() && line[0] != '#') ? 1 : 0;
  return n;
}

TEST_F(CliTest, RunWritesTheThreeTrajectoriesAndTableTwo) {
  const std::string dump_dir = simulate_demo_dump("cli_run_dump", 5.0);
  const std::string out = dump_dir + "_out";
  const test::RunResult r =
      run_cli("run '" + dump_dir + "' --bim '" + demo_model() + "' -o '" + out + "' --gt-start --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const Json j = Json::parse(r.out);
  EXPECT_EQ(j.at("localization_status"), "ok");
  EXPECT_FALSE(j.at("localized").get<bool>());
  EXPECT_LT(j.at("initial_error").at("xy").get<double>(), 1e-9);
  const io::FrameDumpReader dump(dump_dir);
  EXPECT_EQ(j.at("frames").get<std::size_t>(), dump.num_frames());
  ASSERT_EQ(j.at("table").size(), 3u);
  const Json& end = j.at("table").at(2);
  EXPECT_EQ(end.at("point"), "end");
  EXPECT_GT(end.at("distance").get<double>(), 4.0);
  EXPECT_LT(end.at("bim").at("error").get<double>(), 0.05);
  EXPECT_LT(j.at("max_error_xy").at("bim").get<double>(), 0.08);
  // The BIM registrations alone, against the truth: most frames register, within the as-built deviations.
  // Per-frame time of BimOdometry and its parts: the front end and the registration run one after
  // the other, the key points (on every core, the CLI's default) beside the front end.
  const Json& t = j.at("mean_seconds_per_frame");
  EXPECT_GT(t.at("process").get<double>(), 0.0);
  EXPECT_GT(t.at("segment").get<double>(), 0.0);
  EXPECT_LE(t.at("front_end").get<double>() + t.at("icp").get<double>(), t.at("process").get<double>() * 1.001);
  EXPECT_LE(t.at("segment").get<double>() + t.at("icp").get<double>(), t.at("process").get<double>() * 1.001);
  const Json& per_frame = j.at("seconds_per_frame");
  EXPECT_GT(per_frame.at("median").get<double>(), 0.0);
  EXPECT_GE(per_frame.at("max").get<double>(), t.at("process").get<double>());
  EXPECT_GE(per_frame.at("max").get<double>(), per_frame.at("median").get<double>());
  EXPECT_LT(per_frame.at("slowest_frame").get<std::size_t>(), dump.num_frames());
  const Json& reg = j.at("registration_error_xy");
  EXPECT_GT(reg.at("count").get<std::size_t>(), dump.num_frames() / 2);
  EXPECT_GT(reg.at("rms").get<double>(), 0.0);
  EXPECT_LT(reg.at("rms").get<double>(), 0.05);
  EXPECT_LE(reg.at("rms").get<double>(), reg.at("max").get<double>());
  for (const char* name : {"wheel.tum", "lidar.tum", "bim.tum"}) {
    EXPECT_EQ(count_lines(out + "/" + name), dump.num_frames()) << name;
  }
  // The corrected trajectory file matches the reported end error against gt.tum.
  const Trajectory bim = io::read_tum(out + "/bim.tum");
  const Trajectory gt = dump.ground_truth();
  ASSERT_EQ(bim.size(), gt.size());
  EXPECT_NEAR((bim.poses.back().translation() - gt.poses.back().translation()).head<2>().norm(),
              end.at("bim").at("error").get<double>(), 1e-4);
  const std::string svg = test::read_text(out + "/trajectory.svg");
  EXPECT_NE(svg.find("BIM-corrected"), std::string::npos);
  EXPECT_NE(svg.find("ground truth"), std::string::npos);
  EXPECT_EQ(Json::parse(test::read_text(out + "/report.json")), j);
  std::filesystem::remove_all(dump_dir);
  std::filesystem::remove_all(out);
}

TEST_F(CliTest, RunOnTheExactModelRegistersWithinACentimetre) {
  // No as-built deviation, no furniture: the model is the world, so the BIM registration alone
  // places the robot within a centimetre (measured 5 mm rms, 11 mm max; the default world's
  // deviations make it 2-4 cm).
  const std::string dir = test::temp_path("cli_run_exact_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  ASSERT_EQ(run_cli("simulate '" + demo_model() + "' -o '" + dir +
                    "' --lidar vlp16 --length 4 --seed 4 --as-built-sigma 0 --as-built-deg 0 --clutter 0")
                .exit_code,
            0);
  const test::RunResult r = run_cli("run '" + dir + "' --bim '" + demo_model() + "' -o '" + dir + "_out' --gt-start --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const Json j = Json::parse(r.out);
  const Json& reg = j.at("registration_error_xy");
  const io::FrameDumpReader dump(dir);
  EXPECT_GT(reg.at("count").get<std::size_t>(), dump.num_frames() * 9 / 10);
  EXPECT_LT(reg.at("rms").get<double>(), 0.01);
  EXPECT_LT(j.at("max_error_xy").at("bim").get<double>(), 0.02);
  std::filesystem::remove_all(dir);
  std::filesystem::remove_all(dir + "_out");
}

TEST_F(CliTest, RunThreadCountDoesNotChangeAnyOutput) {
  // The same run on 1 and 3 threads (chunks spread unevenly over the threads; the frame read
  // ahead on a second thread): trajectories, the as-built deviations and the second pass byte for byte.
  const std::string dir = test::temp_path("cli_run_threads_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  ASSERT_EQ(run_cli("simulate '" + demo_model() + "' -o '" + dir + "' --lidar vlp16 --length 3 --seed 6").exit_code, 0);
  std::vector<std::string> outputs;
  for (const char* threads : {"1", "3"}) {
    const std::string out = dir + "_out" + threads;
    const test::RunResult r = run_cli("run '" + dir + "' --bim '" + demo_model() + "' -o '" + out +
                                      "' --gt-start --as-built --refine --threads " + threads);
    ASSERT_EQ(r.exit_code, 0) << r.err;
    outputs.push_back(test::read_text(out + "/bim.tum") + test::read_text(out + "/lidar.tum") +
                      test::read_text(out + "/deviations.csv") + test::read_text(out + "/bim_refined.tum"));
    std::filesystem::remove_all(out);
  }
  EXPECT_GT(outputs[0].size(), 1000u);
  EXPECT_EQ(outputs[1], outputs[0]);
  EXPECT_NE(run_cli("run '" + dir + "' --bim '" + demo_model() + "' -o '" + dir + "_bad' --threads -2").exit_code, 0);
  std::filesystem::remove_all(dir);
}

// `run --as-built --refine`: a second pass over the building as estimated, written beside the
// online trajectory and reported beside it; --refine alone is a usage error.
TEST_F(CliTest, RunRefineWritesTheSecondPassBesideTheOnlineTrajectory) {
  const std::string dump_dir = simulate_demo_dump("cli_run_refine", 5.0);
  const std::string out = dump_dir + "_out";
  test::RunResult r = run_cli("run '" + dump_dir + "' --bim '" + demo_model() + "' -o '" + out + "' --gt-start --refine");
  EXPECT_GE(r.exit_code, 100);
  EXPECT_NE(r.err.find("--as-built"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(out + "/bim.tum"));
  r = run_cli("run '" + dump_dir + "' --bim '" + demo_model() + "' -o '" + out + "' --gt-start --as-built --refine --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const Json j = Json::parse(r.out);
  const io::FrameDumpReader dump(dump_dir);
  EXPECT_EQ(count_lines(out + "/bim_refined.tum"), dump.num_frames());
  const Trajectory refined = io::read_tum(out + "/bim_refined.tum");
  const Trajectory gt = dump.ground_truth();
  ASSERT_EQ(refined.size(), gt.size());
  const Json& end = j.at("table").at(2);
  EXPECT_NEAR((refined.poses.back().translation() - gt.poses.back().translation()).head<2>().norm(),
              end.at("bim_refined").at("error").get<double>(), 1e-4);
  EXPECT_GT(j.at("max_error_xy").at("bim_refined").get<double>(), 0.0);
  EXPECT_LT(j.at("max_error_xy").at("bim_refined").get<double>(), 0.08);
  EXPECT_LE(j.at("ape_rmse_xy").at("bim_refined").get<double>(), j.at("max_error_xy").at("bim_refined").get<double>());
  EXPECT_GT(j.at("seconds_refine").get<double>(), 0.0);
  EXPECT_NE(test::read_text(out + "/trajectory.svg").find("second pass"), std::string::npos);
  // Without --refine, no second pass and no trace of one.
  r = run_cli("run '" + dump_dir + "' --bim '" + demo_model() + "' -o '" + out + "_online' --gt-start --as-built --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_FALSE(std::filesystem::exists(out + "_online/bim_refined.tum"));
  EXPECT_FALSE(Json::parse(r.out).at("max_error_xy").contains("bim_refined"));
  // The first pass is the online run, unchanged by the second: trajectory and deviation report.
  EXPECT_EQ(test::read_text(out + "_online/bim.tum"), test::read_text(out + "/bim.tum"));
  EXPECT_EQ(test::read_text(out + "_online/deviations.csv"), test::read_text(out + "/deviations.csv"));
  std::filesystem::remove_all(dump_dir);
  std::filesystem::remove_all(out);
  std::filesystem::remove_all(out + "_online");
}

TEST_F(CliTest, RunWithoutWheelOdometryOrWithBadOptionsFailsClearly) {
  const std::string dump_dir = simulate_demo_dump("cli_run_bad_dump", 1.0);
  const std::string out = dump_dir + "_out";
  test::RunResult r;
  r = run_cli("run '" + dump_dir + "' --bim '" + demo_model() + "' -o '" + out + "' --start-hint 1");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("start-hint"), std::string::npos) << r.err;
  r = run_cli("run '" + dump_dir + "' --bim '" + demo_model() + "' -o '" + out + "' --start-hint 1 2 --start-hint-radius -1");
  EXPECT_NE(r.exit_code, 0);
  // The as-built is estimated from the BIM registrations: with --no-bim there would be no report.
  r = run_cli("run '" + dump_dir + "' --bim '" + demo_model() + "' -o '" + out + "' --gt-start --no-bim --as-built");
  EXPECT_GE(r.exit_code, 100);
  EXPECT_NE(r.err.find("--no-bim"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(out + "/bim.tum"));
  // No odom.csv: the front end has no prior; the message names the file.
  std::filesystem::remove(dump_dir + "/odom.csv");
  r = run_cli("run '" + dump_dir + "' --bim '" + demo_model() + "' -o '" + out + "'");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("odom.csv"), std::string::npos) << r.err;
  // Options a user gets wrong.
  r = run_cli("run '" + dump_dir + "' -o '" + out + "'");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("--bim"), std::string::npos) << r.err;
  r = run_cli("run '" + dump_dir + "_missing' --bim '" + demo_model() + "' -o '" + out + "'");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("_missing"), std::string::npos) << r.err;
  std::filesystem::remove_all(dump_dir);
  std::filesystem::remove_all(out);
}

/// The viewpoint files of the archive `bcf`, one after the other, after validating every XML of it
/// against the BCF 2.1 schemas; `topics` is set to the number of topics.
std::string bcf_viewpoints(const std::string& bcf, std::size_t& topics) {
  const std::string dir = bcf + "_x";
  std::filesystem::remove_all(dir);
  test::extract_bcf(bcf, dir);
  topics = (test::expect_valid_bcf_files(dir) - 2) / 2;
  std::string text;
  for (const auto& e : std::filesystem::recursive_directory_iterator(dir)) {
    if (e.path().filename() == "viewpoint.bcfv") text += test::read_text(e.path().string());
  }
  std::filesystem::remove_all(dir);
  return text;
}

// `run --as-built` writes deviations.{json,csv,svg,bcf}: the SVG has one shape per row of the JSON,
// grey (dashed) for the unobserved ones; the BCF validates and has one topic per deviating row,
// selecting that row's GlobalId. With a tolerance nothing exceeds, the BCF is still written, valid,
// without topics. A user's deviations.bcf in OUT is refused and left as it was.
// The duplex's two flats are the same flat turned half a turn: a start inside one cannot be told
// from the same spot in the other, however far the robot drives in it. The run says so, names both
// places and asks for a hint; with the hint it runs.
TEST_F(CliTest, RunWithAStartThatFitsTwoPlacesNamesBothAndTakesAHint) {
  PLUMB_REQUIRE_DATA(duplex, "ifc/buildings/duplex.ifc");
  const std::string dir = test::temp_path("cli_run_twin_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  ASSERT_EQ(run_cli("simulate '" + duplex + "' -o '" + dir + "' --length 5 --seed 1").exit_code, 0);
  const std::string out = dir + "_out";
  test::RunResult r = run_cli("run '" + dir + "' --bim '" + duplex + "' -o '" + out + "'");
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_NE(r.err.find("fits two places"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("--start-hint"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("m driven"), std::string::npos) << r.err;  // it drove on before giving up
  EXPECT_FALSE(std::filesystem::exists(out + "/bim.tum"));
  // The true start (gt.tum) rounded to the metre is a hint a site engineer can give.
  std::ifstream gt(dir + "/gt.tum");
  std::string comment;
  double stamp = 0.0, x = 0.0, y = 0.0;
  ASSERT_TRUE(std::getline(gt, comment) && gt >> stamp >> x >> y);
  r = run_cli("run '" + dir + "' --bim '" + duplex + "' -o '" + out + "' --start-hint " + std::to_string(std::round(x)) +
              " " + std::to_string(std::round(y)));
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(std::filesystem::exists(out + "/bim.tum"));
  std::filesystem::remove_all(dir);
  std::filesystem::remove_all(out);
}

TEST_F(CliTest, RunAsBuiltWritesTheFourDeviationFilesAndKeepsAUsersOwn) {
  const std::string dump_dir = simulate_demo_dump("cli_run_as_built_dump", 4.0);
  const std::string out = dump_dir + "_out";
  const std::string run = "run '" + dump_dir + "' --bim '" + demo_model() + "' --gt-start --as-built -o ";
  test::RunResult r = run_cli(run + "'" + out + "'");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("wrote " + out + "/deviations.{json,csv,svg,bcf}"), std::string::npos) << r.out;
  const Json rows = Json::parse(test::read_text(out + "/deviations.json")).at("elements");
  ASSERT_FALSE(rows.empty());
  EXPECT_EQ(count_lines(out + "/deviations.csv"), rows.size() + 1);
  std::size_t unobserved = 0;
  std::vector<std::string> deviating;
  for (const Json& row : rows) {
    unobserved += row.at("status") == "unobserved" ? 1 : 0;
    if (row.at("status") == "deviates") deviating.push_back(row.at("global_id"));
  }
  EXPECT_NE(r.out.find("as built: " + std::to_string(rows.size() - unobserved) + " elements checked"), std::string::npos)
      << r.out;
  const std::string svg = test::read_text(out + "/deviations.svg");
  std::size_t shapes = 0, grey = 0;
  for (std::size_t at = svg.find("<g id=\"element-"); at != std::string::npos; at = svg.find("<g id=\"element-", at + 1)) {
    ++shapes;
    grey += svg.compare(svg.find("class=\"", at), 26, "class=\"element unobserved\"") == 0 ? 1 : 0;
  }
  EXPECT_EQ(shapes, rows.size());
  EXPECT_EQ(grey, unobserved);
  EXPECT_NE(svg.find("offset along the face normal [cm]"), std::string::npos);
  const std::string unavailable = test::bcf_check_unavailable();
  if (unavailable.empty()) {
    std::size_t topics = 0;
    const std::string viewpoints = bcf_viewpoints(out + "/deviations.bcf", topics);
    EXPECT_EQ(topics, deviating.size());
    for (const Json& row : rows) {
      const std::string component = "<Component IfcGuid=\"" + row.at("global_id").get<std::string>() + "\"";
      EXPECT_EQ(viewpoints.find(component) != std::string::npos, row.at("status") == "deviates") << row;
    }
    r = run_cli(run + "'" + out + "' --tolerance 1 --max-frames 5");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    bcf_viewpoints(out + "/deviations.bcf", topics);
    EXPECT_EQ(topics, 0u);
    EXPECT_NE(r.out.find("none deviates beyond 100 cm"), std::string::npos) << r.out;
  }
  // A wider construction tolerance (the estimate's prior) leaves every element less certain.
  r = run_cli(run + "'" + out + "' --as-built-sigma 0.05 --as-built-deg 1");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const Json wide = Json::parse(test::read_text(out + "/deviations.json")).at("elements");
  ASSERT_EQ(wide.size(), rows.size());
  for (std::size_t i = 0; i < rows.size(); ++i) {
    EXPECT_EQ(wide[i].at("global_id"), rows[i].at("global_id"));
    EXPECT_GT(wide[i].at("sigma_m").get<double>(), rows[i].at("sigma_m").get<double>()) << rows[i];
  }
  r = run_cli(run + "'" + out + "' --as-built-sigma 0");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("--as-built-sigma"), std::string::npos) << r.err;
  // A user's file of the same name is refused before any work, and left alone.
  const std::string foreign = dump_dir + "_foreign";
  std::filesystem::remove_all(foreign);
  std::filesystem::create_directories(foreign);
  test::write_text(foreign + "/deviations.bcf", "a user's issues\n");
  r = run_cli(run + "'" + foreign + "'");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("plumb did not write"), std::string::npos) << r.err;
  EXPECT_EQ(test::read_text(foreign + "/deviations.bcf"), "a user's issues\n");
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(foreign), std::filesystem::directory_iterator()), 1);
  std::filesystem::remove_all(dump_dir);
  std::filesystem::remove_all(out);
  std::filesystem::remove_all(foreign);
}

TEST_F(CliTest, DemoRunsTheWholeJobAndReportsTableTwo) {
  const std::string dir = test::temp_path("cli_demo_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  const test::RunResult r = run_cli("demo -o '" + dir + "' --length 6 --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const Json j = Json::parse(r.out);
  // The first frame is localized in the model without a hint (BimLocalizer) ...
  EXPECT_TRUE(j.at("localized").get<bool>());
  EXPECT_EQ(j.at("localization_status"), "ok");
  EXPECT_LT(j.at("initial_error").at("xy").get<double>(), 0.05);
  EXPECT_LT(j.at("initial_error").at("yaw_deg").get<double>(), 0.5);
  EXPECT_NEAR(j.at("simulation").at("path_length").get<double>(), 6.0, 0.5);
  const Json& end = j.at("table").at(2);
  EXPECT_LT(end.at("bim").at("error").get<double>(), 0.05);
  EXPECT_TRUE(std::filesystem::exists(dir + "/demo_office.ifc"));
  EXPECT_TRUE(std::filesystem::exists(dir + "/dump/gt.tum"));
  EXPECT_TRUE(std::filesystem::exists(dir + "/run/trajectory.svg"));
  // ... with the as-built estimate: the deviation report beside the trajectory, summed up.
  for (const char* name : {"json", "csv", "svg", "bcf"}) {
    EXPECT_TRUE(std::filesystem::exists(dir + "/run/deviations." + name)) << name;
  }
  const Json rows = Json::parse(test::read_text(dir + "/run/deviations.json")).at("elements");
  std::size_t unobserved = 0;
  for (const Json& row : rows) unobserved += row.at("status") == "unobserved" ? 1 : 0;
  EXPECT_EQ(j.at("as_built").get<std::string>().rfind(std::to_string(rows.size() - unobserved) + " elements checked (" +
                                                          std::to_string(unobserved) + " unobserved), ",
                                                      0),
            0u)
      << j.at("as_built");
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace plumb
