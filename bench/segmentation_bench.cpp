// SPDX-License-Identifier: BSD-3-Clause
// Scan processing speed (Liu et al. 2022, sec. 2): ground plane on room_scan1 against PCL and
// Open3D plane RANSAC (same 5 cm threshold, 1000-iteration cap, 15 deg axis tolerance for PCL's
// perpendicular-plane model, Open3D single thread), and cloud -> scan and the whole
// segment_frame() on a 32-line frame.
// Counters: inliers found and the plane offset D (n.p = D, m), to see which plane each one found.

#include <cmath>
#include <map>
#include <string>
#include <utility>

#include <benchmark/benchmark.h>

#include "bench_data.hpp"
#include "plumb/io/cloud_io.hpp"
#include "plumb/scan2d/cloud_to_scan.hpp"
#include "plumb/segmentation/ground.hpp"
#include "plumb/segmentation/segment_frame.hpp"

#ifdef PLUMB_BENCH_HAVE_PCL
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/sample_consensus/method_types.h>
#include <pcl/sample_consensus/model_types.h>
#include <pcl/segmentation/sac_segmentation.h>
// SACSegmentation is a template; its body is compiled here (the models come from the linked
// pcl_sample_consensus), so the benchmark needs no pcl_segmentation library.
#include <pcl/segmentation/impl/sac_segmentation.hpp>
#endif
#ifdef PLUMB_BENCH_HAVE_OPEN3D
#include <open3d/geometry/PointCloud.h>
// Open3D parallelises SegmentPlane with OpenMP; the comparison is single thread. Weak, so the
// benchmark links whether or not the OpenMP runtime is loaded.
extern "C" void omp_set_num_threads(int) __attribute__((weak));
#endif

namespace {

constexpr double kThreshold = 0.05;  // [m]
constexpr int kMaxIterations = 1000;
constexpr double kAxisAngle = 15.0 * 3.14159265358979323846 / 180.0;  // Δθ0 [rad]

const plumb::PointCloud* load(const std::string& relative) {
  static std::map<std::string, plumb::PointCloud> clouds;
  auto it = clouds.find(relative);
  if (it == clouds.end()) {
    plumb::PointCloud cloud;
    try {
      cloud = plumb::io::read_cloud(plumb::bench::data_path(relative));
    } catch (const plumb::Error&) {
      cloud.clear();
    }
    it = clouds.emplace(relative, std::move(cloud)).first;
  }
  return it->second.empty() ? nullptr : &it->second;
}

const char* kRoom = "cloud3d/pcl_room_scans/room_scan1.pcd";
const char* kHdl32 = "cloud3d/hdl32_pair/251370668.pcd";

void BM_GroundPlumb(benchmark::State& state) {
  const plumb::PointCloud* cloud = load(kRoom);
  if (cloud == nullptr) {
    state.SkipWithError("room_scan1.pcd not found (PLUMB_DATA_DIR)");
    return;
  }
  plumb::GroundSettings s;
  s.distance_threshold = kThreshold;
  s.max_iterations = kMaxIterations;
  s.max_normal_angle = kAxisAngle;
  plumb::GroundResult r;
  for (auto _ : state) {
    r = plumb::extract_ground(*cloud, s);
    benchmark::DoNotOptimize(r.plane.offset);
  }
  state.counters["inliers"] = static_cast<double>(r.inliers.size());
  state.counters["offset"] = r.plane.offset;
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * cloud->size()));
}
BENCHMARK(BM_GroundPlumb)->Name("ground_plane/plumb/room_scan1")->Unit(benchmark::kMillisecond);

#ifdef PLUMB_BENCH_HAVE_PCL
void BM_GroundPcl(benchmark::State& state) {
  const plumb::PointCloud* cloud = load(kRoom);
  if (cloud == nullptr) {
    state.SkipWithError("room_scan1.pcd not found (PLUMB_DATA_DIR)");
    return;
  }
  pcl::PointCloud<pcl::PointXYZ>::Ptr pc(new pcl::PointCloud<pcl::PointXYZ>);
  for (const auto& p : cloud->points) pc->push_back(pcl::PointXYZ(p.x(), p.y(), p.z()));
  pcl::SACSegmentation<pcl::PointXYZ> seg;
  seg.setOptimizeCoefficients(true);
  seg.setModelType(pcl::SACMODEL_PERPENDICULAR_PLANE);
  seg.setMethodType(pcl::SAC_RANSAC);
  seg.setAxis(Eigen::Vector3f::UnitZ());
  seg.setEpsAngle(kAxisAngle);
  seg.setDistanceThreshold(kThreshold);
  seg.setMaxIterations(kMaxIterations);
  seg.setInputCloud(pc);
  pcl::PointIndices inliers;
  pcl::ModelCoefficients coefficients;
  for (auto _ : state) {
    seg.segment(inliers, coefficients);
    benchmark::DoNotOptimize(inliers.indices.data());
  }
  state.counters["inliers"] = static_cast<double>(inliers.indices.size());
  if (coefficients.values.size() == 4) {
    // PCL: ax + by + cz + d = 0 -> n.p = -d; report D with the normal pointing up.
    const double sign = coefficients.values[2] >= 0 ? 1.0 : -1.0;
    state.counters["offset"] = -sign * coefficients.values[3];
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * cloud->size()));
}
BENCHMARK(BM_GroundPcl)->Name("ground_plane/pcl/room_scan1")->Unit(benchmark::kMillisecond);
#endif

#ifdef PLUMB_BENCH_HAVE_OPEN3D
void BM_GroundOpen3d(benchmark::State& state) {
  const plumb::PointCloud* cloud = load(kRoom);
  if (cloud == nullptr) {
    state.SkipWithError("room_scan1.pcd not found (PLUMB_DATA_DIR)");
    return;
  }
  if (omp_set_num_threads != nullptr) omp_set_num_threads(1);
  open3d::geometry::PointCloud pc;
  pc.points_.reserve(cloud->size());
  for (const auto& p : cloud->points) pc.points_.push_back(p.cast<double>());
  Eigen::Vector4d model = Eigen::Vector4d::Zero();
  std::size_t num_inliers = 0;
  for (auto _ : state) {
    auto [m, inl] = pc.SegmentPlane(kThreshold, 3, kMaxIterations);
    model = m;
    num_inliers = inl.size();
    benchmark::DoNotOptimize(num_inliers);
  }
  state.counters["inliers"] = static_cast<double>(num_inliers);
  const double sign = model(2) >= 0 ? 1.0 : -1.0;
  state.counters["offset"] = -sign * model(3);
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * cloud->size()));
}
BENCHMARK(BM_GroundOpen3d)->Name("ground_plane/open3d/room_scan1")->Unit(benchmark::kMillisecond);
#endif

void BM_CloudToScan(benchmark::State& state) {
  const plumb::PointCloud* cloud = load(kHdl32);
  if (cloud == nullptr) {
    state.SkipWithError("hdl32 frame not found (PLUMB_DATA_DIR)");
    return;
  }
  plumb::CloudToScanSettings s;
  s.min_height = -0.3;
  s.max_height = 0.3;
  s.angle_increment = 3.14159265358979323846 / 720.0;
  for (auto _ : state) {
    const plumb::CloudToScanResult r = plumb::cloud_to_scan(*cloud, s);
    benchmark::DoNotOptimize(r.scan.ranges.data());
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * cloud->size()));
}
BENCHMARK(BM_CloudToScan)->Name("cloud_to_scan/plumb/hdl32")->Unit(benchmark::kMillisecond);

void BM_SegmentFrame(benchmark::State& state) {
  const plumb::PointCloud* cloud = load(kHdl32);
  if (cloud == nullptr) {
    state.SkipWithError("hdl32 frame not found (PLUMB_DATA_DIR)");
    return;
  }
  plumb::SegmentResult r;
  for (auto _ : state) {
    r = plumb::segment_frame(*cloud);
    benchmark::DoNotOptimize(r.labels.data());
  }
  state.counters["ground"] = static_cast<double>(r.num_ground);
  state.counters["vertical"] = static_cast<double>(r.num_vertical);
  state.counters["planes"] = static_cast<double>(r.vertical.planes.size());
  state.counters["sample_ms"] = r.timings.sample * 1e3;
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * cloud->size()));
}
BENCHMARK(BM_SegmentFrame)->Name("segment_frame/plumb/hdl32")->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
