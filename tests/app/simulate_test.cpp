// SPDX-License-Identifier: BSD-3-Clause
// simulate_to_dump(): the frame dump of a short simulated run in the demo office holds exactly the
// frames and readings sim::simulate_scenario() hands out, and read_lidar_model() on files.
#include "plumb/app/simulate.hpp"

#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "cli_runner.hpp"
#include "plumb/bim/ifc.hpp"
#include "plumb/core/error.hpp"
#include "plumb/io/frame_dump.hpp"
#include "test_data.hpp"
#include "test_util.hpp"

namespace plumb {
namespace {

namespace fs = std::filesystem;

const bim::BimMesh& demo_office() {
  static const bim::BimMesh mesh =
      bim::build_mesh(bim::read_ifc(std::string(PLUMB_SOURCE_DIR) + "/examples/data/demo_office.ifc"));
  return mesh;
}

std::string fresh_dir(const std::string& name) {
  const std::string dir = test::temp_path("simulate_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  return dir;
}

/// 1.5 m through the demo office with a 16-line LiDAR of 120 columns: a few dozen small frames.
sim::ScenarioSettings short_run() {
  sim::ScenarioSettings s = sim::scenario_defaults(sim::ScenarioKind::kIndoor);
  s.lidar = sim::lidar_preset("vlp16");
  s.lidar.columns = 120;
  s.loops = 1;
  s.length = 1.5;
  s.seed = 9;
  return s;
}

std::vector<std::string> dump_files(const std::string& dir) {
  std::vector<std::string> files;
  for (const auto& e : fs::recursive_directory_iterator(dir)) {
    if (e.is_regular_file()) files.push_back(fs::relative(e.path(), dir).string());
  }
  std::sort(files.begin(), files.end());
  return files;
}

// Every file of the dump is what io::FrameDumpWriter writes for the frames and readings the
// simulator hands out, under simulated_dump_meta(); the frames read back equal those handed out.
TEST(SimulateToDumpTest, TheDumpHoldsWhatTheSimulatorHandsOut) {
  const sim::ScenarioSettings s = short_run();
  SimulateDumpSettings ds;
  ds.model_name = "demo_office.ifc";
  std::vector<std::pair<std::size_t, std::size_t>> calls;
  ds.progress = [&](std::size_t done, std::size_t total) { calls.emplace_back(done, total); };
  const std::string dir = fresh_dir("dump");
  const sim::ScenarioResult r = simulate_to_dump(demo_office(), dir, s, ds);

  const sim::ScenarioPlan plan = sim::plan_scenario(demo_office(), s);
  std::vector<double> stamps;
  std::vector<PointCloud> clouds;
  const std::string expected = fresh_dir("expected");
  io::FrameDumpWriter writer(expected, simulated_dump_meta(plan, s, "demo_office.ifc"));
  const sim::ScenarioRecording rec =
      sim::simulate_scenario(plan, s, [&](std::size_t, double stamp, const PointCloud& cloud) {
        stamps.push_back(stamp);
        clouds.push_back(cloud);
        writer.add_frame(stamp, cloud);
      });
  writer.close();
  writer.write_wheels(rec.wheels);
  writer.write_odometry(rec.odometry);
  writer.write_imu(rec.imu);
  writer.write_ground_truth(rec.ground_truth);
  writer.write_ground_truth_dense(rec.ground_truth_dense);

  EXPECT_EQ(r.num_frames, rec.summary.num_frames);
  EXPECT_EQ(r.num_points, rec.summary.num_points);
  EXPECT_EQ(r.path_length, rec.summary.path_length);
  ASSERT_GT(r.num_frames, 10u);
  ASSERT_EQ(calls.size(), r.num_frames);
  for (std::size_t i = 0; i < calls.size(); ++i) EXPECT_EQ(calls[i], std::make_pair(i + 1, r.num_frames));

  const std::vector<std::string> files = dump_files(dir);
  EXPECT_EQ(files, dump_files(expected));
  for (const char* f : {"meta.json", "frames.csv", "wheels.csv", "odom.csv", "imu.csv", "gt.tum", "gt_dense.tum"}) {
    EXPECT_NE(std::find(files.begin(), files.end(), f), files.end()) << f;
  }
  for (const std::string& f : files) {
    EXPECT_EQ(test::read_text(dir + "/" + f), test::read_text(expected + "/" + f)) << f;
  }

  const io::FrameDumpReader dump(dir);
  EXPECT_EQ(dump.meta().lidar.name, "vlp16");
  EXPECT_EQ(dump.meta().lidar.columns, 120);
  EXPECT_EQ(dump.meta().model, "demo_office.ifc");
  EXPECT_EQ(dump.meta().source, "plumb simulate (seed 9)");
  EXPECT_EQ(dump.meta().scenario, "indoor");
  EXPECT_EQ(dump.meta().wheel_radius_left, s.wheels.radius);
  EXPECT_EQ(dump.meta().axle, s.wheels.axle);
  EXPECT_TRUE(dump.meta().origin_offset == demo_office().origin_offset);
  EXPECT_EQ(dump.stamps(), stamps);
  for (std::size_t i = 0; i < clouds.size(); ++i) {
    const PointCloud c = dump.frame(i);
    EXPECT_TRUE(c.points == clouds[i].points && c.intensities == clouds[i].intensities &&
                c.rings == clouds[i].rings && c.times == clouds[i].times && c.labels == clouds[i].labels)
        << "frame " << i;
  }
  fs::remove_all(dir);
  fs::remove_all(expected);
}

// A directory holding a dump is refused before any frame is simulated, unless overwrite is set;
// a model the scenario cannot be planned in leaves no directory.
TEST(SimulateToDumpTest, AnExistingDumpIsRefusedBeforeAnyFrame) {
  const std::string dir = fresh_dir("existing");
  sim::ScenarioSettings s = short_run();
  s.length = 0.5;
  simulate_to_dump(demo_office(), dir, s);
  SimulateDumpSettings ds;
  std::size_t frames = 0;
  ds.progress = [&](std::size_t, std::size_t) { ++frames; };
  EXPECT_THROW(simulate_to_dump(demo_office(), dir, s, ds), Error);
  EXPECT_EQ(frames, 0u);
  ds.dump.overwrite = true;
  const std::size_t written = simulate_to_dump(demo_office(), dir, s, ds).num_frames;
  EXPECT_GT(written, 0u);
  EXPECT_EQ(frames, written);
  fs::remove_all(dir);

  sim::ScenarioSettings bad = s;
  bad.loops = 0;
  const std::string none = fresh_dir("bad_settings");
  EXPECT_THROW(simulate_to_dump(demo_office(), none, bad), Error);
  EXPECT_FALSE(fs::exists(none));
}

TEST(ReadLidarModelTest, ReadsAFileAndNamesOneItCannotRead) {
  const std::string path = test::temp_path("lidar_model_" + std::to_string(::getpid()) + ".json");
  test::write_text(path, R"({"preset": "vlp16", "columns": 900})");
  const sim::LidarModel m = read_lidar_model(path);
  EXPECT_EQ(m.name, "vlp16");
  EXPECT_EQ(m.columns, 900);
  EXPECT_EQ(m.elevations_rad.size(), 16u);
  test::write_text(path, R"({"columns": 900})");
  EXPECT_EQ(test::error_of([&] { read_lidar_model(path); }).rfind(path + ": ", 0), 0u);
  fs::remove(path);
  const std::string missing = std::string(PLUMB_BINARY_DIR) + "/no_such_lidar.json";
  EXPECT_NE(test::error_of([&] { read_lidar_model(missing); }).find(missing), std::string::npos);
}

}  // namespace
}  // namespace plumb
