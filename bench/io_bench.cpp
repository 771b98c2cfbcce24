// SPDX-License-Identifier: BSD-3-Clause
// PCD reading: plumb vs PCL (pcl::io::loadPCDFile) vs Open3D (open3d::io::ReadPointCloud) on the
// same files. Every run reads the whole file from disk (page cache warm after the first), so the
// times include the read syscall; NaN points are kept by all three.
#include <benchmark/benchmark.h>

#include <cstdio>
#include <string>

#include "bench_data.hpp"
#include "plumb/io/pcd.hpp"

#ifdef PLUMB_BENCH_HAVE_PCL
#include <pcl/io/pcd_io.h>
#include <pcl/point_types.h>
#endif
#ifdef PLUMB_BENCH_HAVE_OPEN3D
#include <open3d/geometry/PointCloud.h>
#include <open3d/io/PointCloudIO.h>
#endif

namespace {

struct Dataset {
  const char* name;
  const char* relative;
};

// binary_compressed (room_scan1, organized table_scene) and uncompressed binary (hdl32).
const Dataset kDatasets[] = {
    {"room_scan1", "cloud3d/pcl_room_scans/room_scan1.pcd"},
    {"hdl32_251370668", "cloud3d/hdl32_pair/251370668.pcd"},
    {"table_scene_mug", "cloud3d/pcl_test/table_scene_mug_stereo_textured.pcd"},
    {"sac_plane_test_ascii", "cloud3d/pcl_test/sac_plane_test.pcd"},
};

bool exists(const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (f == nullptr) return false;
  std::fclose(f);
  return true;
}

void read_plumb(benchmark::State& state, const std::string& path) {
  std::size_t n = 0;
  for (auto _ : state) {
    plumb::PointCloud cloud = plumb::io::read_pcd(path);
    n = cloud.size();
    benchmark::DoNotOptimize(cloud.points.data());
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * n));
}

#ifdef PLUMB_BENCH_HAVE_PCL
void read_pcl(benchmark::State& state, const std::string& path) {
  std::size_t n = 0;
  for (auto _ : state) {
    pcl::PointCloud<pcl::PointXYZ> cloud;
    if (pcl::io::loadPCDFile(path, cloud) != 0) {
      state.SkipWithError("PCL failed to read the file");
      return;
    }
    n = cloud.size();
    benchmark::DoNotOptimize(cloud.points.data());
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * n));
}
#endif

#ifdef PLUMB_BENCH_HAVE_OPEN3D
void read_open3d(benchmark::State& state, const std::string& path) {
  std::size_t n = 0;
  for (auto _ : state) {
    open3d::geometry::PointCloud cloud;
    if (!open3d::io::ReadPointCloud(path, cloud)) {
      state.SkipWithError("Open3D failed to read the file");
      return;
    }
    n = cloud.points_.size();
    benchmark::DoNotOptimize(cloud.points_.data());
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * n));
}
#endif

int register_all() {
  for (const Dataset& d : kDatasets) {
    const std::string path = plumb::bench::data_path(d.relative);
    if (!exists(path)) continue;
    const std::string suffix = std::string("/") + d.name;
    benchmark::RegisterBenchmark(("pcd_read/plumb" + suffix).c_str(), read_plumb, path)->Unit(benchmark::kMillisecond);
#ifdef PLUMB_BENCH_HAVE_PCL
    benchmark::RegisterBenchmark(("pcd_read/pcl" + suffix).c_str(), read_pcl, path)->Unit(benchmark::kMillisecond);
#endif
#ifdef PLUMB_BENCH_HAVE_OPEN3D
    benchmark::RegisterBenchmark(("pcd_read/open3d" + suffix).c_str(), read_open3d, path)
        ->Unit(benchmark::kMillisecond);
#endif
  }
  return 0;
}

const int kRegistered = register_all();

}  // namespace

BENCHMARK_MAIN();
