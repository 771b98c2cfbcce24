// SPDX-License-Identifier: BSD-3-Clause
// LOAM front end on the real HDL-32E pair (shared/data/cloud3d/hdl32_pair): range image + cosine
// features per frame, and scan-to-scan matching per frame (frames per second = items_per_second).
// "hdl32" is the full 32-ring frame (~69k points); "hdl32_16ring" keeps every other ring (a
// 16-line frame of ~35k points, the paper's sensor class and the speed target).
// No peer library implements LOAM features, so no peer runs here.
#include <benchmark/benchmark.h>

#include <string>

#include "bench_data.hpp"
#include "plumb/io/pcd.hpp"
#include "plumb/loam/features.hpp"
#include "plumb/loam/odometry.hpp"
#include "plumb/loam/range_image.hpp"

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

BENCHMARK_CAPTURE(BM_LoamFeatures, hdl32, false)->Name("loam_features/plumb/hdl32")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_LoamFeatures, hdl32_16ring, true)->Name("loam_features/plumb/hdl32_16ring")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_LoamScanToScan, hdl32, false)->Name("loam_scan_to_scan/plumb/hdl32")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_LoamScanToScan, hdl32_16ring, true)->Name("loam_scan_to_scan/plumb/hdl32_16ring")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_LoamFrame, hdl32, false)->Name("loam_frame/plumb/hdl32")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_LoamFrame, hdl32_16ring, true)->Name("loam_frame/plumb/hdl32_16ring")->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
