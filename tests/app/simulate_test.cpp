// SPDX-License-Identifier: BSD-3-Clause
// simulate_to_dump(): the frame dump of a short simulated run in the demo office holds exactly the
// frames and readings sim::simulate_scenario() hands out, its as_built.json the World's element
// deviations (on which the LiDAR returns lie), and read_lidar_model() on files.
#include "plumb/app/simulate.hpp"

#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "cli_runner.hpp"
#include "plumb/bim/ifc.hpp"
#include "plumb/core/error.hpp"
#include "plumb/io/frame_dump.hpp"
#include "plumb/sim/world.hpp"
#include "test_data.hpp"
#include "test_util.hpp"

namespace plumb {
namespace {

namespace fs = std::filesystem;

const bim::BimMesh& demo_office() {
  static const bim::BimMesh mesh =
      bim::build_mesh(bim::read_ifc(test::source_dir() + "/examples/data/demo_office.ifc"));
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
  writer.write_as_built(rec.as_built);

  EXPECT_EQ(r.num_frames, rec.summary.num_frames);
  EXPECT_EQ(r.num_points, rec.summary.num_points);
  EXPECT_EQ(r.path_length, rec.summary.path_length);
  ASSERT_GT(r.num_frames, 10u);
  ASSERT_EQ(calls.size(), r.num_frames);
  for (std::size_t i = 0; i < calls.size(); ++i) EXPECT_EQ(calls[i], std::make_pair(i + 1, r.num_frames));

  const std::vector<std::string> files = dump_files(dir);
  EXPECT_EQ(files, dump_files(expected));
  for (const char* f :
       {"meta.json", "frames.csv", "wheels.csv", "odom.csv", "imu.csv", "gt.tum", "gt_dense.tum", "as_built.json"}) {
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
  const std::string missing = test::binary_dir() + "/no_such_lidar.json";
  EXPECT_NE(test::error_of([&] { read_lidar_model(missing); }).find(missing), std::string::npos);
}

/// Half a metre through the demo office with a noise-free 16-line LiDAR of 120 columns: a few frames.
sim::ScenarioSettings noise_free_run() {
  sim::ScenarioSettings s = sim::scenario_defaults(sim::ScenarioKind::kIndoor);
  s.lidar = sim::lidar_preset("vlp16");
  s.lidar.columns = 120;
  s.lidar.range_sigma = 0.0;
  s.loops = 1;
  s.length = 0.5;
  s.seed = 4;
  return s;
}

Eigen::Matrix4d matrix_of(const nlohmann::json& numbers) {
  const std::vector<double> m = numbers.get<std::vector<double>>();
  EXPECT_EQ(m.size(), 16u);
  Eigen::Matrix4d M = Eigen::Matrix4d::Zero();
  for (std::size_t k = 0; k < std::min<std::size_t>(m.size(), 16); ++k) M(k / 4, k % 4) = m[k];
  return M;
}

/// Distance from p to the triangle (a, b, c): to the plane when p projects inside, else to the
/// nearest edge.
double point_triangle_distance(const Vector3d& p, const Vector3d& a, const Vector3d& b, const Vector3d& c) {
  const Vector3d n = (b - a).cross(c - a);
  const double area2 = n.squaredNorm();
  if (area2 > 0.0) {
    const Vector3d q = p - n * (n.dot(p - a) / area2);
    const double u = (c - b).cross(q - b).dot(n), v = (a - c).cross(q - c).dot(n), w = (b - a).cross(q - a).dot(n);
    if (u >= 0.0 && v >= 0.0 && w >= 0.0) return (p - q).norm();
  }
  auto segment = [&p](const Vector3d& s0, const Vector3d& s1) {
    const Vector3d d = s1 - s0;
    const double len2 = d.squaredNorm();
    const double t = len2 > 0.0 ? std::clamp(d.dot(p - s0) / len2, 0.0, 1.0) : 0.0;
    return (p - (s0 + t * d)).norm();
  };
  return std::min({segment(a, b), segment(b, c), segment(c, a)});
}

/// Brute-force distance from p to the nearest of `triangles` (corner triples), skipping those
/// whose bounding box is farther than `reach`; `reach` when none is nearer.
double nearest_triangle(const Vector3d& p, const std::vector<std::array<Vector3d, 3>>& triangles, double reach) {
  double best = reach;
  for (const auto& t : triangles) {
    const Vector3d lo = t[0].cwiseMin(t[1]).cwiseMin(t[2]), hi = t[0].cwiseMax(t[1]).cwiseMax(t[2]);
    if (((lo - p).cwiseMax(p - hi)).maxCoeff() > best) continue;
    best = std::min(best, point_triangle_distance(p, t[0], t[1], t[2]));
  }
  return best;
}

// The file holds one entry per element of the model, in order, with its global_id and type, and
// the 16 numbers of World::element_deviation of a World built anew with the plan's world settings,
// bit for bit (read by nlohmann_json, not by plumb's reader).
TEST(AsBuiltDumpTest, TheFileHoldsTheWorldsDeviations) {
  const sim::ScenarioSettings s = noise_free_run();
  const std::string dir = fresh_dir("as_built_deviations");
  simulate_to_dump(demo_office(), dir, s);
  const sim::ScenarioPlan plan = sim::plan_scenario(demo_office(), s);
  const sim::World world(*plan.mesh, plan.world->settings());

  const nlohmann::json doc = nlohmann::json::parse(test::read_text(dir + "/as_built.json"));
  const nlohmann::json& elements = doc.at("elements");
  ASSERT_EQ(elements.size(), demo_office().elements.size());
  std::size_t moved = 0;
  for (std::size_t e = 0; e < elements.size(); ++e) {
    EXPECT_EQ(elements[e].at("global_id").get<std::string>(), demo_office().elements[e].global_id);
    EXPECT_EQ(elements[e].at("type").get<std::string>(), demo_office().elements[e].type);
    const Eigen::Matrix4d M = matrix_of(elements[e].at("T_design_asbuilt"));
    EXPECT_TRUE(M == world.element_deviation(e).matrix()) << e << ":\n" << M;
    if (!world.element_deviation(e).isApprox(Eigen::Isometry3d::Identity(), 1e-9)) ++moved;
  }
  EXPECT_GT(moved, elements.size() / 2);  // the deviations are real

  // plumb's reader gives the same, within the rounding of its orthonormalisation.
  const std::vector<ElementDeviation> read = io::FrameDumpReader(dir).as_built();
  ASSERT_EQ(read.size(), elements.size());
  for (std::size_t e = 0; e < read.size(); ++e) {
    EXPECT_TRUE(read[e].T_design_asbuilt.isApprox(world.element_deviation(e), 1e-14)) << e;
  }
  fs::remove_all(dir);
}

// Noise-free returns off BIM elements (labels ground, wall, other element), put in the world with
// the true LiDAR pose at each point's time, lie on the design triangles moved by as_built.json
// (within 1 mm: float storage), while most of them lie measurably (> 2 mm) off the design.
TEST(AsBuiltDumpTest, LidarHitsLieOnTheAsBuiltSurfaces) {
  const sim::ScenarioSettings s = noise_free_run();
  const std::string dir = fresh_dir("as_built_surfaces");
  simulate_to_dump(demo_office(), dir, s);
  const sim::ScenarioPlan plan = sim::plan_scenario(demo_office(), s);
  const io::FrameDumpReader dump(dir);
  const std::vector<ElementDeviation> as_built = dump.as_built();
  const bim::BimMesh& mesh = demo_office();
  ASSERT_EQ(as_built.size(), mesh.elements.size());

  std::vector<std::array<Vector3d, 3>> design, built;
  for (std::size_t t = 0; t < mesh.num_triangles(); ++t) {
    const std::array<Vector3d, 3> corners = {mesh.vertices[mesh.triangles[t][0]], mesh.vertices[mesh.triangles[t][1]],
                                             mesh.vertices[mesh.triangles[t][2]]};
    const Eigen::Isometry3d& T = as_built.at(static_cast<std::size_t>(mesh.triangle_element[t])).T_design_asbuilt;
    design.push_back(corners);
    built.push_back({T * corners[0], T * corners[1], T * corners[2]});
  }

  std::size_t hits = 0, on_built = 0, off_design = 0;
  ASSERT_GE(dump.num_frames(), 2u);
  for (std::size_t f = 0; f < dump.num_frames(); ++f) {
    const PointCloud cloud = dump.frame(f);
    ASSERT_EQ(cloud.labels.size(), cloud.size());
    for (std::size_t i = 0; i < cloud.size(); i += 3) {
      const std::int32_t label = cloud.labels[i];
      if (label != sim::kSimGround && label != sim::kSimWall && label != sim::kSimOtherElement) continue;
      const double t = dump.stamp(f) + static_cast<double>(cloud.times[i]);
      const Vector3d p = plan.trajectory.T_world_base(t) * s.T_base_lidar * cloud.points[i].cast<double>();
      ++hits;
      if (nearest_triangle(p, built, 0.05) < 1e-3) ++on_built;
      if (nearest_triangle(p, design, 0.05) > 2e-3) ++off_design;
    }
  }
  ASSERT_GT(hits, 500u);
  EXPECT_GE(static_cast<double>(on_built), 0.995 * static_cast<double>(hits)) << on_built << " of " << hits;
  EXPECT_GE(static_cast<double>(off_design), 0.4 * static_cast<double>(hits)) << off_design << " of " << hits;
  fs::remove_all(dir);
}

}  // namespace
}  // namespace plumb
