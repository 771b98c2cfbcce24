// SPDX-License-Identifier: BSD-3-Clause
// Normals (PCA) and FPFH: plumb against PCL (NormalEstimation, FPFHEstimation, not the OMP
// variants) and Open3D (EstimateNormals, ComputeFPFHFeature, OpenMP limited to one thread), on
// room_scan1 voxel-downsampled to 0.1 m by plumb's voxel_grid, single thread.
// Equal work: radius 0.5 m, at most 100 neighbours (plumb and Open3D: hybrid search; PCL has no
// cap, which rarely matters here: a 0.5 m disc on a 0.1 m grid holds ~80 points). FPFH runs on the
// same normals (plumb's, computed once) for all three. Every timed call builds its own kd-tree, as
// each library does inside its feature call.
// Names: normals/<impl>/room_scan1, fpfh/<impl>/room_scan1.


#include <fstream>
#include <memory>
#include <string>

#include <benchmark/benchmark.h>

#include "plumb/features/fpfh.hpp"
#include "plumb/features/normals.hpp"
#include "plumb/filters/voxel_grid.hpp"
#include "plumb/io/pcd.hpp"

#ifdef PLUMB_BENCH_HAVE_PCL
#include <pcl/features/fpfh.h>
#include <pcl/features/fpfh_omp.h>
#include <pcl/features/normal_3d.h>
#include <pcl/features/normal_3d_omp.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/search/kdtree.h>
#endif
#ifdef PLUMB_BENCH_HAVE_OPEN3D
#include <open3d/geometry/KDTreeSearchParam.h>
#include <open3d/geometry/PointCloud.h>
#include <open3d/pipelines/registration/Feature.h>
#endif

#include "bench_data.hpp"

namespace {

constexpr double kVoxel = 0.1;     // [m]
constexpr float kRadius = 0.5f;    // [m]
constexpr std::size_t kMaxNn = 100;
const char* const kDataset = "room_scan1";

/// room_scan1 downsampled, with plumb's normals (oriented to the sensor at the origin).
/// Empty when the data file is missing.
const plumb::PointCloud& cloud() {
  static const plumb::PointCloud c = [] {
    const std::string path = plumb::bench::data_path("cloud3d/pcl_room_scans/room_scan1.pcd");
    plumb::PointCloud out;
    if (!std::ifstream(path).good()) return out;
    plumb::VoxelGridSettings vs;
    vs.leaf_size = kVoxel;
    out = plumb::voxel_grid(plumb::io::read_pcd(path), vs).cloud;
    plumb::NormalSettings ns;
    ns.k = kMaxNn;
    ns.radius = kRadius;
    plumb::compute_normals(out, ns);
    return out;
  }();
  return c;
}

bool require(benchmark::State& state) {
  if (!cloud().empty()) return true;
  state.SkipWithError("data not found: room_scan1 (set PLUMB_DATA_DIR)");
  return false;
}

void finish(benchmark::State& state) {
  state.counters["points"] = static_cast<double>(cloud().size());
  state.SetItemsProcessed(state.iterations() * static_cast<int64_t>(cloud().size()));
}

void bm_normals_plumb_threads(benchmark::State& state, int threads) {
  if (!require(state)) return;
  const plumb::PointCloud& c = cloud();
  plumb::NormalSettings ns;
  ns.k = kMaxNn;
  ns.radius = kRadius;
  ns.threads = threads;
  for (auto _ : state) {
    const plumb::KdTree<3> tree(c.points);
    plumb::NormalResult r = plumb::estimate_normals(c.points, tree, c.points, ns);
    benchmark::DoNotOptimize(r.normals.data());
  }
  finish(state);
}

void bm_normals_plumb(benchmark::State& state) { bm_normals_plumb_threads(state, 1); }

void bm_fpfh_plumb_threads(benchmark::State& state, int threads) {
  if (!require(state)) return;
  plumb::FpfhSettings fs;
  fs.radius = kRadius;
  fs.max_neighbors = kMaxNn;
  fs.threads = threads;
  for (auto _ : state) {
    plumb::FpfhResult r = plumb::compute_fpfh(cloud(), fs);
    benchmark::DoNotOptimize(r.features.data());
  }
  finish(state);
}

void bm_fpfh_plumb(benchmark::State& state) { bm_fpfh_plumb_threads(state, 1); }

#ifdef PLUMB_BENCH_HAVE_PCL
pcl::PointCloud<pcl::PointXYZ>::Ptr pcl_points() {
  auto out = std::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  for (const auto& p : cloud().points) out->push_back(pcl::PointXYZ(p.x(), p.y(), p.z()));
  return out;
}

// One timed PCL estimate per iteration, with the plain estimator or its OpenMP twin (`args` are
// the constructor's: the OpenMP ones take the thread count).
template <class Estimator, class... Args>
void pcl_normals(benchmark::State& state, Args... args) {
  if (!require(state)) return;
  const auto pts = pcl_points();
  pcl::PointCloud<pcl::Normal> out;
  for (auto _ : state) {
    Estimator ne(args...);
    ne.setInputCloud(pts);
    ne.setSearchMethod(std::make_shared<pcl::search::KdTree<pcl::PointXYZ>>());
    ne.setRadiusSearch(kRadius);
    ne.setViewPoint(0.0f, 0.0f, 0.0f);
    ne.compute(out);
    benchmark::DoNotOptimize(out.points.data());
  }
  finish(state);
}

template <class Estimator, class... Args>
void pcl_fpfh(benchmark::State& state, Args... args) {
  if (!require(state)) return;
  const auto pts = pcl_points();
  auto normals = std::make_shared<pcl::PointCloud<pcl::Normal>>();
  for (const auto& n : cloud().normals) normals->push_back(pcl::Normal(n.x(), n.y(), n.z()));
  pcl::PointCloud<pcl::FPFHSignature33> out;
  for (auto _ : state) {
    Estimator fe(args...);
    fe.setInputCloud(pts);
    fe.setInputNormals(normals);
    fe.setSearchMethod(std::make_shared<pcl::search::KdTree<pcl::PointXYZ>>());
    fe.setRadiusSearch(kRadius);
    fe.compute(out);
    benchmark::DoNotOptimize(out.points.data());
  }
  finish(state);
}

void bm_normals_pcl(benchmark::State& state) { pcl_normals<pcl::NormalEstimation<pcl::PointXYZ, pcl::Normal>>(state); }
void bm_fpfh_pcl(benchmark::State& state) {
  pcl_fpfh<pcl::FPFHEstimation<pcl::PointXYZ, pcl::Normal, pcl::FPFHSignature33>>(state);
}

// PCL's OpenMP estimators, the same work on N threads.
void bm_normals_pcl_omp(benchmark::State& state, int threads) {
  pcl_normals<pcl::NormalEstimationOMP<pcl::PointXYZ, pcl::Normal>>(state, static_cast<unsigned>(threads));
}
void bm_fpfh_pcl_omp(benchmark::State& state, int threads) {
  pcl_fpfh<pcl::FPFHEstimationOMP<pcl::PointXYZ, pcl::Normal, pcl::FPFHSignature33>>(state, static_cast<unsigned>(threads));
}
#endif

#ifdef PLUMB_BENCH_HAVE_OPEN3D
open3d::geometry::PointCloud o3d_cloud(bool with_normals) {
  open3d::geometry::PointCloud out;
  for (const auto& p : cloud().points) out.points_.push_back(p.cast<double>());
  if (with_normals) {
    for (const auto& n : cloud().normals) out.normals_.push_back(n.cast<double>());
  }
  return out;
}

void bm_normals_open3d(benchmark::State& state) {
  if (!require(state)) return;
  const open3d::geometry::PointCloud in = o3d_cloud(false);
  const open3d::geometry::KDTreeSearchParamHybrid param(kRadius, static_cast<int>(kMaxNn));
  for (auto _ : state) {
    state.PauseTiming();
    open3d::geometry::PointCloud c = in;  // without normals, as a fresh estimate needs
    state.ResumeTiming();
    c.EstimateNormals(param, /*fast_normal_computation=*/true);
    c.OrientNormalsTowardsCameraLocation(Eigen::Vector3d::Zero());
    benchmark::DoNotOptimize(c.normals_.data());
  }
  finish(state);
}

void bm_fpfh_open3d(benchmark::State& state) {
  if (!require(state)) return;
  const open3d::geometry::PointCloud in = o3d_cloud(true);
  const open3d::geometry::KDTreeSearchParamHybrid param(kRadius, static_cast<int>(kMaxNn));
  for (auto _ : state) {
    auto f = open3d::pipelines::registration::ComputeFPFHFeature(in, param);
    benchmark::DoNotOptimize(f->data_.data());
  }
  finish(state);
}

// Open3D parallelises both with OpenMP: the same work on N OpenMP threads.
void bm_normals_open3d_threads(benchmark::State& state, int threads) {
  plumb::bench::with_openmp_threads(state, threads, bm_normals_open3d);
}
void bm_fpfh_open3d_threads(benchmark::State& state, int threads) {
  plumb::bench::with_openmp_threads(state, threads, bm_fpfh_open3d);
}
#endif

}  // namespace

int main(int argc, char** argv) {
  plumb::bench::single_thread_openmp();
  const std::string ds = kDataset;
  plumb::bench::register_with_peers("normals", ds, bm_normals_plumb, PLUMB_BENCH_PCL(bm_normals_pcl),
                                    PLUMB_BENCH_OPEN3D(bm_normals_open3d));
  plumb::bench::register_threads("normals/plumb/" + ds, bm_normals_plumb_threads);
  plumb::bench::register_threads("fpfh/plumb/" + ds, bm_fpfh_plumb_threads);
#ifdef PLUMB_BENCH_HAVE_PCL
  plumb::bench::register_threads("normals/pcl_omp/" + ds, bm_normals_pcl_omp);
  plumb::bench::register_threads("fpfh/pcl_omp/" + ds, bm_fpfh_pcl_omp);
#endif
#ifdef PLUMB_BENCH_HAVE_OPEN3D
  if (plumb::bench::have_openmp()) {
    plumb::bench::register_threads("normals/open3d/" + ds, bm_normals_open3d_threads);
    plumb::bench::register_threads("fpfh/open3d/" + ds, bm_fpfh_open3d_threads);
  }
#endif
  plumb::bench::register_with_peers("fpfh", ds, bm_fpfh_plumb, PLUMB_BENCH_PCL(bm_fpfh_pcl),
                                    PLUMB_BENCH_OPEN3D(bm_fpfh_open3d));
  return plumb::bench::run_benchmarks(argc, argv);
}
