// SPDX-License-Identifier: BSD-3-Clause
// LOAM front end on the real HDL-32E pair (shared/data/cloud3d/hdl32_pair): range image + cosine
// features per frame, and scan-to-scan matching per frame (frames per second = items_per_second).
// "hdl32" is the full 32-ring frame (~69k points); "hdl32_16ring" keeps every other ring (a
// 16-line frame of ~35k points: the sensor class of Zhou et al. 2021, for which the target is
// ≥ 50 frames/s).
// No peer library implements LOAM features, so no peer runs here.
// lio_frame/plumb/site16: one frame of the LiDAR/IMU hybrid odometry (deskew, features, joint
// IMU + LiDAR solve, local map update) on a simulated 16-line site run around FZK-Haus
// (vlp16 + 300 Hz IMU, simulated once before timing), frames processed in order;
// lio_frame_icp the same frames all sent to the hybrid's ICP residuals; local_map_update/plumb/site16
// the upkeep of the LIO's point map alone over the same frames.
#include <benchmark/benchmark.h>

#include <filesystem>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include <unistd.h>

#include "bench_data.hpp"
#include "plumb/app/simulate.hpp"
#include "plumb/bim/ifc.hpp"
#include "plumb/bim/mesh.hpp"
#include "plumb/io/frame_dump.hpp"
#include "plumb/io/pcd.hpp"
#include "plumb/loam/features.hpp"
#include "plumb/loam/local_map.hpp"
#include "plumb/loam/odometry.hpp"
#include "plumb/loam/range_image.hpp"
#include "plumb/pipeline/hybrid_lio.hpp"
#include "plumb/sim/scenario.hpp"

namespace {

using namespace plumb;

RangeImageSettings hdl32_image() {
  RangeImageSettings s;
  s.horizontal_resolution_deg = 0.16;
  return s;
}

// Frame `name` of the pair; with `every_other_ring`, only the even rings of the 32 (found by
// auto-binning the elevations), as a 16-line frame with a ring field.
const PointCloud& frame(const std::string& name, bool every_other_ring) {
  static PointCloud cache[2][2];
  const int a = name == "251370668" ? 0 : 1, b = every_other_ring ? 1 : 0;
  PointCloud& c = cache[a][b];
  if (c.empty()) {
    const PointCloud full = io::read_pcd(bench::data_path("cloud3d/hdl32_pair/" + name + ".pcd"));
    if (!every_other_ring) {
      c = full;
    } else {
      int rows = 0;
      const auto ring = auto_bin_rings(full, hdl32_image(), rows);
      for (std::size_t i = 0; i < full.size(); ++i) {
        if (ring[i] == RangeImage::kNoRing || ring[i] % 2 != 0) continue;
        c.points.push_back(full.points[i]);
        c.rings.push_back(static_cast<std::uint16_t>(ring[i] / 2));
      }
    }
  }
  return c;
}

void BM_LoamFeatures(benchmark::State& state, bool sixteen) {
  const PointCloud& cloud = frame("251371071", sixteen);
  for (auto _ : state) {
    LoamFeatures f = extract_loam_features(cloud, hdl32_image(), LoamFeatureSettings{});
    benchmark::DoNotOptimize(f.planes.points.data());
  }
  state.SetItemsProcessed(state.iterations());
  state.counters["points"] = static_cast<double>(cloud.size());
}

void BM_LoamScanToScan(benchmark::State& state, bool sixteen) {
  const LoamFeatures prev = extract_loam_features(frame("251370668", sixteen), hdl32_image(), LoamFeatureSettings{});
  const LoamFeatures cur = extract_loam_features(frame("251371071", sixteen), hdl32_image(), LoamFeatureSettings{});
  int iterations = 0;
  for (auto _ : state) {
    LoamResult r = loam_scan_to_scan(prev, cur, Eigen::Isometry3d::Identity());
    iterations = r.iterations;
    benchmark::DoNotOptimize(r.T_prev_cur.data());
  }
  state.SetItemsProcessed(state.iterations());
  state.counters["solver_iterations"] = iterations;
}

// One whole front-end frame: features of the new frame + scan-to-scan against the previous one.
void BM_LoamFrame(benchmark::State& state, bool sixteen) {
  const LoamFeatures prev = extract_loam_features(frame("251370668", sixteen), hdl32_image(), LoamFeatureSettings{});
  const PointCloud& cloud = frame("251371071", sixteen);
  for (auto _ : state) {
    const LoamFeatures cur = extract_loam_features(cloud, hdl32_image(), LoamFeatureSettings{});
    LoamResult r = loam_scan_to_scan(prev, cur, Eigen::Isometry3d::Identity());
    benchmark::DoNotOptimize(r.T_prev_cur.data());
  }
  state.SetItemsProcessed(state.iterations());
}

// A 16-line site run: 1 s standing, then driving along the house (the LOAM part of the route).
struct SiteRun {
  std::vector<PointCloud> frames;
  std::vector<double> stamps;
  std::vector<ImuSample> imu;
  Eigen::Isometry3d T0 = Eigen::Isometry3d::Identity();
  std::vector<Eigen::Isometry3d> T_world_lidar;  ///< per frame, from the simulator's ground truth
  HybridLioSettings settings;
};

const SiteRun& site16() {
  static std::unique_ptr<SiteRun> run;
  if (run) return *run;
  run = std::make_unique<SiteRun>();
  const std::string dir = "/tmp/plumb_bench_site16_" + std::to_string(::getpid());
  std::filesystem::remove_all(dir);
  sim::ScenarioSettings s = sim::scenario_defaults(sim::ScenarioKind::kSite);
  s.length = 12.0;
  s.seed = 2;
  simulate_to_dump(bim::build_mesh(bim::read_ifc(bench::data_path("ifc/buildings/AC20-FZK-Haus.ifc"))), dir, s);
  const io::FrameDumpReader dump(dir);
  for (std::size_t i = 0; i < dump.num_frames(); ++i) {
    run->frames.push_back(dump.frame(i));
    run->stamps.push_back(dump.stamp(i));
  }
  run->imu = dump.imu();
  run->T0 = dump.ground_truth().poses.front();
  for (const Eigen::Isometry3d& T_world_base : dump.ground_truth().poses) {
    run->T_world_lidar.push_back(T_world_base * dump.meta().T_base_lidar);
  }
  run->settings.T_base_lidar = dump.meta().T_base_lidar;
  run->settings.T_base_imu = dump.meta().T_base_imu;
  std::filesystem::remove_all(dir);
  return *run;
}

// every_frame_icp: the hybrid switch sends every frame to ICP (a plane threshold no frame reaches),
// so the ICP frames' cost (point-to-distribution pairs and the LOAM residuals beside them) is timed.
void BM_LioFrame(benchmark::State& state, LioMode mode, bool every_frame_icp, int threads = 1) {
  const SiteRun& run = site16();
  HybridLioSettings s = run.settings;
  s.mode = mode;
  s.threads = threads;
  if (every_frame_icp) s.features.min_plane_points = std::numeric_limits<std::size_t>::max();
  std::unique_ptr<HybridLio> lio;
  auto restart = [&] {
    lio = std::make_unique<HybridLio>(run.T0, s);
    for (const ImuSample& m : run.imu) lio->add_imu(m);
    lio->process(run.frames[0], run.stamps[0]);  // the first frame only starts the map
  };
  restart();
  bench::time_frames_in_order(state, 1, run.frames.size(), restart, [&](std::size_t i) {
    const LioFrameResult r = lio->process(run.frames[i], run.stamps[i]);
    benchmark::DoNotOptimize(r.T_world_base.data());
  });
  state.counters["points_per_frame"] = static_cast<double>(run.frames.back().size());
}

// The LIO's ICP point map kept over the run (HybridLio's default point_map settings): each frame
// at its true pose inserted, then the map pruned around the sensor. Returns beyond the map's
// 60 m reach are inserted and dropped again every frame, which is what made the upkeep costly in
// whole runs when a prune rebuilt the map's index.
void BM_LocalMapUpdate(benchmark::State& state) {
  const SiteRun& run = site16();
  if (run.T_world_lidar.size() != run.frames.size()) {
    state.SkipWithError("ground truth and frames differ in number");
    return;
  }
  const VoxelHashMapSettings settings = run.settings.map.point_map;
  std::unique_ptr<VoxelHashMap> map;
  std::vector<Vector3f> world;
  auto restart = [&] { map = std::make_unique<VoxelHashMap>(settings); };
  restart();
  bench::time_frames_in_order(state, 0, run.frames.size(), restart, [&](std::size_t i) {
    const Eigen::Matrix3f R = run.T_world_lidar[i].linear().cast<float>();
    const Eigen::Vector3f t = run.T_world_lidar[i].translation().cast<float>();
    world.clear();
    for (const Vector3f& p : run.frames[i].points) world.push_back(R * p + t);
    map->insert(world);
    map->prune(run.T_world_lidar[i].translation());
    benchmark::DoNotOptimize(map->num_points());
  });
}
BENCHMARK(BM_LocalMapUpdate)->Name("local_map_update/plumb/site16")->Unit(benchmark::kMillisecond);

BENCHMARK_CAPTURE(BM_LioFrame, site16, LioMode::kHybrid, false)->Name("lio_frame/plumb/site16")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_LioFrame, site16_icp, LioMode::kHybrid, true)
    ->Name("lio_frame_icp/plumb/site16")
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_LioFrame, site16_loam, LioMode::kLoam, false)
    ->Name("lio_frame_loam_only/plumb/site16")
    ->Unit(benchmark::kMillisecond);

void BM_LioFrameThreads(benchmark::State& state, int threads) { BM_LioFrame(state, LioMode::kHybrid, false, threads); }
const bool kLioThreadsRegistered = (bench::register_threads("lio_frame/plumb/site16", BM_LioFrameThreads), true);

BENCHMARK_CAPTURE(BM_LoamFeatures, hdl32, false)->Name("loam_features/plumb/hdl32")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_LoamFeatures, hdl32_16ring, true)->Name("loam_features/plumb/hdl32_16ring")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_LoamScanToScan, hdl32, false)->Name("loam_scan_to_scan/plumb/hdl32")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_LoamScanToScan, hdl32_16ring, true)->Name("loam_scan_to_scan/plumb/hdl32_16ring")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_LoamFrame, hdl32, false)->Name("loam_frame/plumb/hdl32")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_LoamFrame, hdl32_16ring, true)->Name("loam_frame/plumb/hdl32_16ring")->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
