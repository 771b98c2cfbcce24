// SPDX-License-Identifier: BSD-3-Clause
// KdTree build, kNN-10 and NN-1 against nanoflann, PCL and Open3D on real clouds (single thread).
// Names: kdtree_{build,knn10,nn1}/<impl>/<dataset>, and plumb's kdtree_refit (also on two threads)
// and kdtree_knn10_refitted (a tree whose points moved; no peer has one). Queries are a fixed strided
// subset of the cloud's own points (kNumQueries), the same for every implementation; trees are
// built outside the timed loop for queries. Datasets missing from the data dir are skipped with a note on stderr.

#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "plumb/core/point_cloud.hpp"
#include "plumb/io/pcd.hpp"
#include "plumb/search/kdtree.hpp"

#ifdef PLUMB_BENCH_HAVE_NANOFLANN
#include <nanoflann.hpp>
#endif
#ifdef PLUMB_BENCH_HAVE_PCL
#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#endif
#ifdef PLUMB_BENCH_HAVE_OPEN3D
#include <open3d/geometry/KDTreeFlann.h>
#endif

#include "bench_data.hpp"

namespace {

constexpr std::size_t kNumQueries = 20000;
constexpr std::size_t kLeafSize = 10;  // nanoflann's default, used for plumb and nanoflann alike

/// plumb's defaults except the leaf size, stated so the comparison stays equal if a default moves.
plumb::KdTreeSettings plumb_settings() {
  plumb::KdTreeSettings settings;
  settings.leaf_size = kLeafSize;
  return settings;
}

using plumb::bench::data_dir;

struct Dataset {
  std::string name;
  std::vector<Eigen::Vector3f> points;   // finite points of the cloud
  std::vector<Eigen::Vector3f> queries;  // kNumQueries of them, strided
};

std::unique_ptr<Dataset> load(const std::string& name, const std::string& relative) {
  const std::string path = data_dir() + "/" + relative;
  if (!std::ifstream(path).good()) {
    std::fprintf(stderr, "search_bench: skipping %s (%s not found)\n", name.c_str(), path.c_str());
    return nullptr;
  }
  const plumb::PointCloud cloud = plumb::io::read_pcd(path);
  auto ds = std::make_unique<Dataset>();
  ds->name = name;
  for (const auto& p : cloud.points) {
    if (p.allFinite()) ds->points.push_back(p);
  }
  const std::size_t n = ds->points.size();
  const std::size_t m = std::min(n, kNumQueries);
  for (std::size_t i = 0; i < m; ++i) ds->queries.push_back(ds->points[i * n / m]);
  return ds;
}

// ---- plumb ------------------------------------------------------------------------------------

void plumb_build(benchmark::State& state, const Dataset* ds) {
  for (auto _ : state) {
    plumb::KdTree3f tree(ds->points, plumb_settings());
    benchmark::DoNotOptimize(tree.num_nodes());
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * ds->points.size()));
}

void plumb_knn10(benchmark::State& state, const Dataset* ds) {
  const plumb::KdTree3f tree(ds->points, plumb_settings());
  std::size_t idx[10];
  float d[10];
  for (auto _ : state) {
    for (const auto& q : ds->queries) {
      benchmark::DoNotOptimize(tree.knn(q, 10, idx, d));
      benchmark::DoNotOptimize(d[9]);
    }
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * ds->queries.size()));
}

/// The dataset's points shifted by 1 cm and turned by 0.2 degrees about z around their first
/// point: how far a building's element moves from its design (the as-built registration target).
std::vector<Eigen::Vector3f> moved_a_little(const Dataset* ds) {
  const Eigen::Vector3f pivot = ds->points.front();
  const Eigen::Matrix3f R = Eigen::AngleAxisf(0.2f * 3.14159265f / 180.0f, Eigen::Vector3f::UnitZ()).toRotationMatrix();
  std::vector<Eigen::Vector3f> out(ds->points.size());
  for (std::size_t i = 0; i < out.size(); ++i) {
    out[i] = R * (ds->points[i] - pivot) + pivot + Eigen::Vector3f(0.01f, -0.01f, 0.005f);
  }
  return out;
}

// A tree moved to the points moved a little, and back, each iteration one refit: the work a
// rebuild does (kdtree_build) when a cloud deforms. No peer refits a tree; theirs rebuild.
void plumb_refit_on(benchmark::State& state, const Dataset* ds, int threads) {
  const std::vector<Eigen::Vector3f> moved = moved_a_little(ds);
  plumb::KdTree3f tree(ds->points, plumb_settings());
  bool there = false;
  for (auto _ : state) {
    there = !there;
    tree.refit(there ? moved : ds->points, threads);
    benchmark::DoNotOptimize(tree.size());
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * ds->points.size()));
}
void plumb_refit(benchmark::State& state, const Dataset* ds) { plumb_refit_on(state, ds, 1); }
// The same on two threads (kdtree_refit/plumb_2threads): the one multi-threaded row of this file.
void plumb_refit_2threads(benchmark::State& state, const Dataset* ds) { plumb_refit_on(state, ds, 2); }

// kNN-10 in a tree refitted to the moved points, at the moved queries: against kdtree_knn10, what
// the kept cells cost the queries.
void plumb_knn10_refitted(benchmark::State& state, const Dataset* ds) {
  const std::vector<Eigen::Vector3f> moved = moved_a_little(ds);
  plumb::KdTree3f tree(ds->points, plumb_settings());
  tree.refit(moved);
  const std::size_t n = moved.size();
  const std::size_t m = ds->queries.size();
  std::vector<Eigen::Vector3f> queries(m);
  for (std::size_t i = 0; i < m; ++i) queries[i] = moved[i * n / m];
  std::size_t idx[10];
  float d[10];
  for (auto _ : state) {
    for (const auto& q : queries) {
      benchmark::DoNotOptimize(tree.knn(q, 10, idx, d));
      benchmark::DoNotOptimize(d[9]);
    }
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * m));
}

void plumb_nn1(benchmark::State& state, const Dataset* ds) {
  const plumb::KdTree3f tree(ds->points, plumb_settings());
  for (auto _ : state) {
    for (const auto& q : ds->queries) {
      auto nb = tree.nearest(q);
      benchmark::DoNotOptimize(nb);
    }
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * ds->queries.size()));
}

// ---- nanoflann 1.4.3 --------------------------------------------------------------------------
#ifdef PLUMB_BENCH_HAVE_NANOFLANN
struct NanoCloud {
  const std::vector<Eigen::Vector3f>* pts;
  std::size_t kdtree_get_point_count() const { return pts->size(); }
  float kdtree_get_pt(std::size_t i, std::size_t dim) const { return (*pts)[i][static_cast<int>(dim)]; }
  template <class Box>
  bool kdtree_get_bbox(Box& /*box*/) const { return false;  }
};
using NanoTree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<float, NanoCloud>,
                                                     NanoCloud, 3>;

void nanoflann_build(benchmark::State& state, const Dataset* ds) {
  const NanoCloud cloud{&ds->points};
  for (auto _ : state) {
    NanoTree tree(3, cloud, nanoflann::KDTreeSingleIndexAdaptorParams(kLeafSize));
    benchmark::DoNotOptimize(tree.root_node);
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * ds->points.size()));
}

void nanoflann_knn10(benchmark::State& state, const Dataset* ds) {
  const NanoCloud cloud{&ds->points};
  const NanoTree tree(3, cloud, nanoflann::KDTreeSingleIndexAdaptorParams(kLeafSize));
  std::uint32_t idx[10];
  float d[10];
  for (auto _ : state) {
    for (const auto& q : ds->queries) {
      benchmark::DoNotOptimize(tree.knnSearch(q.data(), 10, idx, d));
      benchmark::DoNotOptimize(d[9]);
    }
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * ds->queries.size()));
}

void nanoflann_nn1(benchmark::State& state, const Dataset* ds) {
  const NanoCloud cloud{&ds->points};
  const NanoTree tree(3, cloud, nanoflann::KDTreeSingleIndexAdaptorParams(kLeafSize));
  std::uint32_t idx[1];
  float d[1];
  for (auto _ : state) {
    for (const auto& q : ds->queries) {
      benchmark::DoNotOptimize(tree.knnSearch(q.data(), 1, idx, d));
      benchmark::DoNotOptimize(d[0]);
    }
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * ds->queries.size()));
}
#endif

// ---- PCL 1.13 (FLANN) -------------------------------------------------------------------------
#ifdef PLUMB_BENCH_HAVE_PCL
pcl::PointCloud<pcl::PointXYZ>::Ptr to_pcl(const std::vector<Eigen::Vector3f>& pts) {
  auto cloud = std::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  cloud->reserve(pts.size());
  for (const auto& p : pts) cloud->push_back(pcl::PointXYZ(p.x(), p.y(), p.z()));
  return cloud;
}

void pcl_build(benchmark::State& state, const Dataset* ds) {
  const auto cloud = to_pcl(ds->points);
  for (auto _ : state) {
    pcl::KdTreeFLANN<pcl::PointXYZ> tree;
    tree.setInputCloud(cloud);
    benchmark::DoNotOptimize(tree.getEpsilon());
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * ds->points.size()));
}

void pcl_knn(benchmark::State& state, const Dataset* ds, int k) {
  const auto cloud = to_pcl(ds->points);
  pcl::KdTreeFLANN<pcl::PointXYZ> tree;
  tree.setInputCloud(cloud);
  const auto queries = to_pcl(ds->queries);
  std::vector<int> idx(static_cast<std::size_t>(k));
  std::vector<float> d(static_cast<std::size_t>(k));
  for (auto _ : state) {
    for (const auto& q : *queries) {
      benchmark::DoNotOptimize(tree.nearestKSearch(q, k, idx, d));
      benchmark::DoNotOptimize(d.data());
    }
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * ds->queries.size()));
}
void pcl_knn10(benchmark::State& state, const Dataset* ds) { pcl_knn(state, ds, 10); }
void pcl_nn1(benchmark::State& state, const Dataset* ds) { pcl_knn(state, ds, 1); }
#endif

// ---- Open3D 0.16 ------------------------------------------------------------------------------
#ifdef PLUMB_BENCH_HAVE_OPEN3D
Eigen::MatrixXd to_open3d(const std::vector<Eigen::Vector3f>& pts) {
  Eigen::MatrixXd m(3, static_cast<Eigen::Index>(pts.size()));
  for (std::size_t i = 0; i < pts.size(); ++i) m.col(static_cast<Eigen::Index>(i)) = pts[i].cast<double>();
  return m;
}

void open3d_build(benchmark::State& state, const Dataset* ds) {
  const Eigen::MatrixXd data = to_open3d(ds->points);
  for (auto _ : state) {
    open3d::geometry::KDTreeFlann tree;
    benchmark::DoNotOptimize(tree.SetMatrixData(data));
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * ds->points.size()));
}

void open3d_knn(benchmark::State& state, const Dataset* ds, int k) {
  const Eigen::MatrixXd data = to_open3d(ds->points);
  const open3d::geometry::KDTreeFlann tree(data);
  std::vector<Eigen::Vector3d> queries;
  for (const auto& q : ds->queries) queries.push_back(q.cast<double>());
  std::vector<int> idx;
  std::vector<double> d;
  for (auto _ : state) {
    for (const auto& q : queries) {
      benchmark::DoNotOptimize(tree.SearchKNN(q, k, idx, d));
      benchmark::DoNotOptimize(d.data());
    }
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * ds->queries.size()));
}
void open3d_knn10(benchmark::State& state, const Dataset* ds) { open3d_knn(state, ds, 10); }
void open3d_nn1(benchmark::State& state, const Dataset* ds) { open3d_knn(state, ds, 1); }
#endif

using BenchFn = void (*)(benchmark::State&, const Dataset*);

void add(const std::string& task, const std::string& impl, const Dataset* ds, BenchFn fn) {
  const std::string name = task + "/" + impl + "/" + ds->name;
  benchmark::RegisterBenchmark(name.c_str(), fn, ds)->Unit(benchmark::kMillisecond);
}

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  std::vector<std::unique_ptr<Dataset>> datasets;
  if (auto ds = load("room_scan1", "cloud3d/pcl_room_scans/room_scan1.pcd")) datasets.push_back(std::move(ds));
  if (auto ds = load("hdl32", "cloud3d/hdl32_pair/251370668.pcd")) datasets.push_back(std::move(ds));
  for (const auto& dsp : datasets) {
    const Dataset* ds = dsp.get();
    struct Impl {
      const char* name;
      BenchFn build, knn10, nn1;
    };
    std::vector<Impl> impls{{"plumb", plumb_build, plumb_knn10, plumb_nn1}};
#ifdef PLUMB_BENCH_HAVE_NANOFLANN
    impls.push_back({"nanoflann", nanoflann_build, nanoflann_knn10, nanoflann_nn1});
#endif
#ifdef PLUMB_BENCH_HAVE_PCL
    impls.push_back({"pcl", pcl_build, pcl_knn10, pcl_nn1});
#endif
#ifdef PLUMB_BENCH_HAVE_OPEN3D
    impls.push_back({"open3d", open3d_build, open3d_knn10, open3d_nn1});
#endif
    for (const Impl& impl : impls) add("kdtree_build", impl.name, ds, impl.build);
    for (const Impl& impl : impls) add("kdtree_knn10", impl.name, ds, impl.knn10);
    for (const Impl& impl : impls) add("kdtree_nn1", impl.name, ds, impl.nn1);
    add("kdtree_refit", "plumb", ds, plumb_refit);
    add("kdtree_refit", "plumb_2threads", ds, plumb_refit_2threads);
    add("kdtree_knn10_refitted", "plumb", ds, plumb_knn10_refitted);
  }
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
