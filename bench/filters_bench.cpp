// SPDX-License-Identifier: BSD-3-Clause
// Voxel-grid downsampling: plumb (centroid = like-for-like with the peers, and nearest-to-centroid,
// plumb's default, as in Liu et al. 2022, sec. 1.2) against PCL's VoxelGrid<PointXYZ> and Open3D's
// VoxelDownSample, on the same real clouds at a 0.1 m leaf, single thread. Conversion to the peers'
// cloud types happens once, outside the timed loops. Names: voxel_grid/<impl>/<dataset>.

#include <cstdlib>
#include <fstream>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>

#include "plumb/filters/voxel_grid.hpp"
#include "plumb/io/pcd.hpp"

#ifdef PLUMB_BENCH_HAVE_PCL
#include <pcl/filters/voxel_grid.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#endif
#ifdef PLUMB_BENCH_HAVE_OPEN3D
#include <open3d/geometry/PointCloud.h>
#endif

#include "bench_data.hpp"

namespace {

constexpr double kLeaf = 0.1;  // [m]

using plumb::bench::data_dir;

const std::map<std::string, std::string>& datasets() {
  static const std::map<std::string, std::string> d = {
      {"room_scan1", "cloud3d/pcl_room_scans/room_scan1.pcd"},
      {"hdl32", "cloud3d/hdl32_pair/251370668.pcd"},
  };
  return d;
}

/// Cloud of a dataset, read once; empty when the file is missing.
const plumb::PointCloud& load(const std::string& name) {
  static std::map<std::string, plumb::PointCloud> cache;
  auto it = cache.find(name);
  if (it != cache.end()) return it->second;
  plumb::PointCloud cloud;
  const std::string path = data_dir() + "/" + datasets().at(name);
  if (std::ifstream(path).good()) cloud = plumb::io::read_pcd(path);
  return cache.emplace(name, std::move(cloud)).first->second;
}

bool require(benchmark::State& state, const plumb::PointCloud& cloud, const std::string& name) {
  if (!cloud.empty()) return true;
  state.SkipWithError(("data not found: " + name + " (set PLUMB_DATA_DIR)").c_str());
  return false;
}

void bm_plumb(benchmark::State& state, const std::string& name, plumb::VoxelMode mode) {
  const plumb::PointCloud& cloud = load(name);
  if (!require(state, cloud, name)) return;
  plumb::VoxelGridSettings settings;
  settings.leaf_size = kLeaf;
  settings.mode = mode;
  std::size_t out = 0;
  for (auto _ : state) {
    plumb::VoxelGridResult r = plumb::voxel_grid(cloud, settings);
    out = r.cloud.size();
    benchmark::DoNotOptimize(r.cloud.points.data());
  }
  state.counters["out_points"] = static_cast<double>(out);
  state.SetItemsProcessed(state.iterations() * static_cast<int64_t>(cloud.size()));
}

#ifdef PLUMB_BENCH_HAVE_PCL
void bm_pcl(benchmark::State& state, const std::string& name) {
  const plumb::PointCloud& cloud = load(name);
  if (!require(state, cloud, name)) return;
  auto in = std::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  in->reserve(cloud.size());
  for (const auto& p : cloud.points) in->push_back(pcl::PointXYZ(p.x(), p.y(), p.z()));
  pcl::VoxelGrid<pcl::PointXYZ> filter;
  filter.setInputCloud(in);
  filter.setLeafSize(static_cast<float>(kLeaf), static_cast<float>(kLeaf), static_cast<float>(kLeaf));
  pcl::PointCloud<pcl::PointXYZ> out;
  for (auto _ : state) {
    filter.filter(out);
    benchmark::DoNotOptimize(out.points.data());
  }
  state.counters["out_points"] = static_cast<double>(out.size());
  state.SetItemsProcessed(state.iterations() * static_cast<int64_t>(cloud.size()));
}
#endif

#ifdef PLUMB_BENCH_HAVE_OPEN3D
void bm_open3d(benchmark::State& state, const std::string& name) {
  const plumb::PointCloud& cloud = load(name);
  if (!require(state, cloud, name)) return;
  open3d::geometry::PointCloud in;
  in.points_.reserve(cloud.size());
  for (const auto& p : cloud.points) in.points_.push_back(p.cast<double>());
  std::size_t out = 0;
  for (auto _ : state) {
    std::shared_ptr<open3d::geometry::PointCloud> r = in.VoxelDownSample(kLeaf);
    out = r->points_.size();
    benchmark::DoNotOptimize(r->points_.data());
  }
  state.counters["out_points"] = static_cast<double>(out);
  state.SetItemsProcessed(state.iterations() * static_cast<int64_t>(cloud.size()));
}
#endif

}  // namespace

int main(int argc, char** argv) {
  for (const auto& [name, path] : datasets()) {
    benchmark::RegisterBenchmark(("voxel_grid/plumb/" + name).c_str(),
                                 [name = name](benchmark::State& s) {
                                   bm_plumb(s, name, plumb::VoxelMode::kCentroid);
                                 })->Unit(benchmark::kMillisecond);
    benchmark::RegisterBenchmark(("voxel_grid/plumb_nearest/" + name).c_str(),
                                 [name = name](benchmark::State& s) {
                                   bm_plumb(s, name, plumb::VoxelMode::kNearestToCentroid);
                                 })->Unit(benchmark::kMillisecond);
#ifdef PLUMB_BENCH_HAVE_PCL
    benchmark::RegisterBenchmark(("voxel_grid/pcl/" + name).c_str(),
                                 [name = name](benchmark::State& s) { bm_pcl(s, name); })
        ->Unit(benchmark::kMillisecond);
#endif
#ifdef PLUMB_BENCH_HAVE_OPEN3D
    benchmark::RegisterBenchmark(("voxel_grid/open3d/" + name).c_str(),
                                 [name = name](benchmark::State& s) { bm_open3d(s, name); })
        ->Unit(benchmark::kMillisecond);
#endif
  }
  return plumb::bench::run_benchmarks(argc, argv);
}
