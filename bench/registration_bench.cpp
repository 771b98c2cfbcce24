// SPDX-License-Identifier: BSD-3-Clause
// Global registration and ICP: plumb against PCL (SampleConsensusInitialAlignment,
// IterativeClosestPoint) and Open3D (RegistrationRANSACBasedOnFeatureMatching, RegistrationICP,
// OpenMP limited to one thread), single thread, on the same clouds and the same features.
//
// global_registration/<impl>/room_scan1: room_scan1 voxelised at 0.3 m (normals, FPFH radius
//   1.5 m, computed once by plumb and given to all three) against itself moved by a fixed large
//   transform; counter `success` = 1 when the result is within 0.3 m / 3 deg of the truth. Every
//   source signature has an exact twin in the target here, so this is the easy case.
// global_registration/<impl>/room_scan2_to_1: the same with room_scan2 (another scan of the room,
//   from another place) as the source: signatures differ, the real case. Truth = the fine
//   point-to-plane reference of the icp benchmarks composed with the fixed transform.
// icp/<impl>/room_scan1: room_scan2 voxelised at 0.1 m to the full room_scan1, point-to-point,
//   max correspondence distance 1 m, at most 50 iterations, from the NDT tutorial's guess; each
//   timed run builds its target kd-tree. Counters: the result's offset `dt_mm` / `dr_mdeg` from a
//   fine point-to-plane reference, `iterations` where the library reports it.

// PCL's SVD transformation estimation instantiates Eigen::umeyama<float> here, and GCC 12 reports a
// false -Warray-bounds inside Eigen's packet loads of it (a 3-vector read through a 4-float packet
// on a branch that never runs). The warning is emitted at Eigen's lines, which were included
// before PCL's headers, so it can only be silenced for the whole file.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Warray-bounds"
#endif


#include <cmath>
#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <benchmark/benchmark.h>

#include "plumb/features/fpfh.hpp"
#include "plumb/features/normals.hpp"
#include "plumb/filters/voxel_grid.hpp"
#include "plumb/io/cloud_io.hpp"
#include "plumb/registration/icp.hpp"
#include "plumb/registration/localize.hpp"
#include "plumb/registration/sac_ia.hpp"

#ifdef PLUMB_BENCH_HAVE_PCL
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/registration/ia_ransac.h>
#include <pcl/registration/icp.h>
#endif
#ifdef PLUMB_BENCH_HAVE_OPEN3D
#include <open3d/geometry/PointCloud.h>
#include <open3d/pipelines/registration/CorrespondenceChecker.h>
#include <open3d/pipelines/registration/Feature.h>
#include <open3d/pipelines/registration/Registration.h>
#endif

#include "bench_data.hpp"

namespace {

const char* const kDataset = "room_scan1";
constexpr double kCoarseVoxel = 0.3;
constexpr double kDeg = M_PI / 180.0;

plumb::PointCloud voxel(const plumb::PointCloud& c, double leaf) {
  plumb::VoxelGridSettings vs;
  vs.leaf_size = leaf;
  return plumb::voxel_grid(c.select(c.finite_indices()), vs).cloud;
}

Eigen::Isometry3d pose(double yaw, const Eigen::Vector3d& t) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = t;
  return T;
}

std::pair<double, double> pose_error(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  const Eigen::Isometry3d d = b.inverse() * a;
  return {d.translation().norm(), Eigen::AngleAxisd(d.linear()).angle()};
}

struct GlobalData {
  plumb::PointCloud target, source;
  std::vector<plumb::FpfhSignature> target_features, source_features;
  Eigen::Isometry3d T_target_source_true;
  plumb::LocalizeSettings settings = plumb::localize_settings_for_voxel(kCoarseVoxel);
};

/// Normals and FPFH of a cloud already voxelised at kCoarseVoxel, with the localizer's radii.
std::vector<plumb::FpfhSignature> coarse_features(plumb::PointCloud& c, const plumb::LocalizeSettings& settings) {
  plumb::NormalSettings ns;
  ns.k = settings.normal_neighbors;
  ns.radius = static_cast<float>(settings.normal_radius_factor * kCoarseVoxel);
  plumb::compute_normals(c, ns);
  plumb::FpfhSettings fs;
  fs.radius = static_cast<float>(settings.fpfh_radius_factor * kCoarseVoxel);
  return plumb::compute_fpfh(c, fs).features;
}

/// `source_scan` (voxelised, its normals and features computed in its own frame) moved by a
/// fixed large transform, against room_scan1 voxelised. T_scan1_source: the source scan's true
/// pose in room_scan1.
GlobalData make_global_data(const plumb::PointCloud& source_scan, const Eigen::Isometry3d& T_scan1_source) {
  GlobalData g;
  g.target = voxel(plumb::io::read_cloud(plumb::bench::data_path("cloud3d/pcl_room_scans/room_scan1.pcd")), kCoarseVoxel);
  g.target_features = coarse_features(g.target, g.settings);
  plumb::PointCloud src = voxel(source_scan, kCoarseVoxel);
  g.source_features = coarse_features(src, g.settings);
  const Eigen::Isometry3d T_moved_source = pose(2.2, Eigen::Vector3d(7.0, -4.0, 0.3));
  g.source = plumb::transformed(src, T_moved_source);
  g.T_target_source_true = T_scan1_source * T_moved_source.inverse();
  return g;
}

const GlobalData& global_self() {
  static const GlobalData d = make_global_data(
      plumb::io::read_cloud(plumb::bench::data_path("cloud3d/pcl_room_scans/room_scan1.pcd")),
      Eigen::Isometry3d::Identity());
  return d;
}

const GlobalData& global_pair();  // after icp_data(), whose reference it uses

void report_success(benchmark::State& state, const Eigen::Isometry3d& T, const Eigen::Isometry3d& truth) {
  const auto e = pose_error(T, truth);
  state.counters["success"] = e.first < 0.3 && e.second < 3 * kDeg ? 1.0 : 0.0;
  state.counters["dt_m"] = e.first;
}

void bm_global_plumb(benchmark::State& state, const GlobalData& (*data)()) {
  const GlobalData& g = data();
  plumb::SacIaSettings s = g.settings.sac_ia;
  s.huber_threshold = g.settings.huber_factor * kCoarseVoxel;
  s.max_correspondence_distance = g.settings.correspondence_factor * kCoarseVoxel;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  int iterations = 0;
  for (auto _ : state) {
    const plumb::KdTree3f tree(g.target);
    const plumb::SacIaResult r =
        plumb::align_sac_ia(g.source, g.source_features, g.target, g.target_features, tree, s);
    benchmark::DoNotOptimize(r.score);
    T = r.T_target_source;
    iterations = r.iterations;
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * g.source.size()));
  state.counters["iterations"] = iterations;
  report_success(state, T, g.T_target_source_true);
}

struct IcpData {
  plumb::PointCloud source, target, target_with_normals;
  Eigen::Isometry3d guess, reference;
};

const IcpData& icp_data() {
  static const IcpData d = [] {
    IcpData c;
    const std::string dir = plumb::bench::data_path("cloud3d/pcl_room_scans/");
    c.target = plumb::io::read_cloud(dir + "room_scan1.pcd");
    c.source = voxel(plumb::io::read_cloud(dir + "room_scan2.pcd"), 0.1);
    c.guess = pose(0.6931, Eigen::Vector3d(1.79387, 0.720047, 0));
    // Reference: point-to-plane on 5 cm clouds, distances shrinking to 0.1 m.
    plumb::PointCloud t5 = voxel(c.target, 0.05);
    plumb::NormalSettings ns;
    ns.k = 20;
    ns.radius = 0.15f;
    plumb::compute_normals(t5, ns);
    plumb::IcpSettings is;
    is.method = plumb::IcpMethod::kPointToPlane;
    is.max_correspondence_distance = 0.5;
    is.min_overlap = 1.0;  // run every round down to 0.1 m
    is.max_iterations = 100;
    c.reference = plumb::align_icp(voxel(plumb::io::read_cloud(dir + "room_scan2.pcd"), 0.05), t5, c.guess, is).T_target_source;
    return c;
  }();
  return d;
}

const GlobalData& global_pair() {
  static const GlobalData d = make_global_data(
      plumb::io::read_cloud(plumb::bench::data_path("cloud3d/pcl_room_scans/room_scan2.pcd")), icp_data().reference);
  return d;
}

void report_icp(benchmark::State& state, const Eigen::Isometry3d& T, const IcpData& c) {
  const auto e = pose_error(T, c.reference);
  state.counters["dt_mm"] = e.first * 1e3;
  state.counters["dr_mdeg"] = e.second / kDeg * 1e3;
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * c.source.size()));
}

void bm_icp_plumb_threads(benchmark::State& state, int threads) {
  const IcpData& c = icp_data();
  plumb::IcpSettings s;
  s.max_correspondence_distance = 1.0;
  s.min_overlap = 0.0;  // one round: plain ICP at d = 1 m
  s.max_iterations = 50;
  s.threads = threads;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  int iterations = 0;
  for (auto _ : state) {
    const plumb::KdTree3f tree(c.target);
    const plumb::IcpResult r = plumb::align_icp(c.source, c.target, tree, c.guess, s);
    benchmark::DoNotOptimize(r.rmse);
    T = r.T_target_source;
    iterations = r.iterations;
  }
  state.counters["iterations"] = iterations;
  report_icp(state, T, c);
}

void bm_icp_plumb(benchmark::State& state) { bm_icp_plumb_threads(state, 1); }

#ifdef PLUMB_BENCH_HAVE_PCL
pcl::PointCloud<pcl::PointXYZ>::Ptr to_pcl(const plumb::PointCloud& c) {
  auto out = std::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  out->reserve(c.size());
  for (const auto& p : c.points) out->push_back(pcl::PointXYZ(p.x(), p.y(), p.z()));
  return out;
}

pcl::PointCloud<pcl::FPFHSignature33>::Ptr to_pcl(const std::vector<plumb::FpfhSignature>& features) {
  auto feats = std::make_shared<pcl::PointCloud<pcl::FPFHSignature33>>();
  for (const auto& f : features) {
    pcl::FPFHSignature33 s;
    for (int b = 0; b < 33; ++b) s.histogram[b] = f[static_cast<std::size_t>(b)];
    feats->push_back(s);
  }
  return feats;
}

void bm_global_pcl(benchmark::State& state, const GlobalData& (*data)()) {
  const GlobalData& g = data();
  auto src = to_pcl(g.source);
  auto tgt = to_pcl(g.target);
  auto src_feats = to_pcl(g.source_features);
  auto tgt_feats = to_pcl(g.target_features);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  for (auto _ : state) {
    pcl::SampleConsensusInitialAlignment<pcl::PointXYZ, pcl::PointXYZ, pcl::FPFHSignature33> sac;
    sac.setInputSource(src);
    sac.setSourceFeatures(src_feats);
    sac.setInputTarget(tgt);
    sac.setTargetFeatures(tgt_feats);
    sac.setMinSampleDistance(static_cast<float>(g.settings.sac_ia.min_sample_distance));
    sac.setMaxCorrespondenceDistance(g.settings.correspondence_factor * kCoarseVoxel);
    sac.setMaximumIterations(1000);
    sac.setCorrespondenceRandomness(static_cast<int>(g.settings.sac_ia.k_correspondences));
    pcl::PointCloud<pcl::PointXYZ> out;
    sac.align(out);
    T.matrix() = sac.getFinalTransformation().cast<double>();
    benchmark::DoNotOptimize(out.size());
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * g.source.size()));
  report_success(state, T, g.T_target_source_true);
}

void bm_icp_pcl(benchmark::State& state) {
  const IcpData& c = icp_data();
  auto src = to_pcl(c.source);
  auto tgt = to_pcl(c.target);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  for (auto _ : state) {
    pcl::IterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ> icp;
    icp.setInputSource(src);
    icp.setInputTarget(tgt);
    icp.setMaxCorrespondenceDistance(1.0);
    icp.setMaximumIterations(50);
    pcl::PointCloud<pcl::PointXYZ> out;
    icp.align(out, c.guess.matrix().cast<float>());
    T.matrix() = icp.getFinalTransformation().cast<double>();
    benchmark::DoNotOptimize(out.size());
  }
  report_icp(state, T, c);
}
#endif

#ifdef PLUMB_BENCH_HAVE_OPEN3D
namespace reg = open3d::pipelines::registration;

open3d::geometry::PointCloud to_open3d(const plumb::PointCloud& c) {
  open3d::geometry::PointCloud out;
  out.points_.reserve(c.size());
  for (const auto& p : c.points) out.points_.push_back(p.cast<double>());
  return out;
}

reg::Feature to_open3d(const std::vector<plumb::FpfhSignature>& features) {
  reg::Feature feats;
  feats.Resize(33, static_cast<int>(features.size()));
  for (std::size_t i = 0; i < features.size(); ++i)
    for (int b = 0; b < 33; ++b) feats.data_(b, static_cast<Eigen::Index>(i)) = features[i][static_cast<std::size_t>(b)];
  return feats;
}

void bm_global_open3d(benchmark::State& state, const GlobalData& (*data)()) {
  const GlobalData& g = data();
  const auto src = to_open3d(g.source);
  const auto tgt = to_open3d(g.target);
  const reg::Feature src_feats = to_open3d(g.source_features);
  const reg::Feature tgt_feats = to_open3d(g.target_features);
  const double dist = 1.5 * kCoarseVoxel;
  const reg::CorrespondenceCheckerBasedOnEdgeLength edge(0.9);
  const reg::CorrespondenceCheckerBasedOnDistance close(dist);
  const std::vector<std::reference_wrapper<const reg::CorrespondenceChecker>> checkers = {edge, close};
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  for (auto _ : state) {
    const reg::RegistrationResult r = reg::RegistrationRANSACBasedOnFeatureMatching(
        src, tgt, src_feats, tgt_feats, /*mutual_filter=*/false, dist, reg::TransformationEstimationPointToPoint(false), 3,
        checkers, reg::RANSACConvergenceCriteria(100000, 0.999));
    T.matrix() = r.transformation_;
    benchmark::DoNotOptimize(r.fitness_);
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * g.source.size()));
  report_success(state, T, g.T_target_source_true);
}

void bm_icp_open3d(benchmark::State& state) {
  const IcpData& c = icp_data();
  const auto src = to_open3d(c.source);
  const auto tgt = to_open3d(c.target);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  for (auto _ : state) {
    const reg::RegistrationResult r = reg::RegistrationICP(src, tgt, 1.0, c.guess.matrix(),
                                                           reg::TransformationEstimationPointToPoint(false),
                                                           reg::ICPConvergenceCriteria(1e-6, 1e-6, 50));
    T.matrix() = r.transformation_;
    benchmark::DoNotOptimize(r.fitness_);
  }
  report_icp(state, T, c);
}

// Open3D's ICP parallelises its correspondence search with OpenMP: the same work on N threads.
void bm_icp_open3d_threads(benchmark::State& state, int threads) {
  plumb::bench::with_openmp_threads(state, threads, bm_icp_open3d);
}
#endif

}  // namespace

int main(int argc, char** argv) {
  plumb::bench::single_thread_openmp();
  const std::string ds = kDataset;
  using GlobalBm = void (*)(benchmark::State&, const GlobalData& (*)());
  auto global_bm = [](const std::string& name, GlobalBm fn, const GlobalData& (*data)()) {
    benchmark::RegisterBenchmark(name.c_str(), fn, data)->Unit(benchmark::kMillisecond);
  };
  for (const auto& [suffix, data] : {std::pair<std::string, const GlobalData& (*)()>{ds, global_self},
                                     std::pair<std::string, const GlobalData& (*)()>{"room_scan2_to_1", global_pair}}) {
    global_bm("global_registration/plumb/" + suffix, bm_global_plumb, data);
#ifdef PLUMB_BENCH_HAVE_PCL
    global_bm("global_registration/pcl_sacia/" + suffix, bm_global_pcl, data);
#endif
#ifdef PLUMB_BENCH_HAVE_OPEN3D
    global_bm("global_registration/open3d/" + suffix, bm_global_open3d, data);
#endif
  }
  plumb::bench::register_with_peers("icp", ds, bm_icp_plumb, PLUMB_BENCH_PCL(bm_icp_pcl),
                                    PLUMB_BENCH_OPEN3D(bm_icp_open3d));
  plumb::bench::register_threads("icp/plumb/" + ds, bm_icp_plumb_threads);
#ifdef PLUMB_BENCH_HAVE_OPEN3D
  if (plumb::bench::have_openmp()) plumb::bench::register_threads("icp/open3d/" + ds, bm_icp_open3d_threads);
#endif
  return plumb::bench::run_benchmarks(argc, argv);
}
