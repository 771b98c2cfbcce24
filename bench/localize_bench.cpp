// SPDX-License-Identifier: BSD-3-Clause
// Finding a robot's first LiDAR frame in a building model, no initial guess: plumb's BimLocalizer
// (floor-plan branch and bound + ICP), the chain of Liu et al. 2022, sec. 1, as plumb implements it
// (localize_coarse_to_fine: FPFH + SAC-IA + ICP), and Open3D (FPFH + RANSAC feature matching +
// point-to-plane ICP), on the same simulated frames of AC20-FZK-Haus against the same BIM cloud.
// Each benchmark iteration localizes one frame (cycling through 5); the counter `found` is the
// fraction of frames localized within 5 cm / 0.5 deg of the simulator's ground truth.

#include <benchmark/benchmark.h>

#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "bench_data.hpp"
#include "plumb/bim/bim_cloud.hpp"
#include "plumb/bim/ifc.hpp"
#include "plumb/bim/mesh.hpp"
#include "plumb/core/rng.hpp"
#include "plumb/pipeline/bim_localizer.hpp"
#include "plumb/registration/localize.hpp"
#include "plumb/sim/lidar.hpp"
#include "plumb/sim/scenario.hpp"

#ifdef PLUMB_BENCH_HAVE_OPEN3D
#include <open3d/geometry/PointCloud.h>
#include <open3d/pipelines/registration/Feature.h>
#include <open3d/pipelines/registration/Registration.h>
#endif

namespace {

struct Data {
  bool ok = false;
  std::unique_ptr<plumb::bim::BimMesh> mesh;
  plumb::PointCloud bim_cloud;
  Eigen::Isometry3d T_base_lidar = Eigen::Isometry3d::Identity();
  std::vector<plumb::PointCloud> frames;
  std::vector<Eigen::Isometry3d> truth;  ///< T_world_base per frame
};

const Data& data() {
  static Data d = [] {
    Data out;
    const std::string path = plumb::bench::data_path("ifc/buildings/AC20-FZK-Haus.ifc");
    try {
      out.mesh = std::make_unique<plumb::bim::BimMesh>(plumb::bim::build_mesh(plumb::bim::read_ifc(path)));
    } catch (const std::exception&) {
      return out;
    }
    out.bim_cloud = plumb::bim::sample_bim_cloud(*out.mesh, 0.05);
    plumb::sim::ScenarioSettings s = plumb::sim::scenario_defaults(plumb::sim::ScenarioKind::kIndoor);
    s.seed = 11;
    const plumb::sim::ScenarioPlan plan = plumb::sim::plan_scenario(*out.mesh, s);
    out.T_base_lidar = s.T_base_lidar;
    plumb::Rng rng(2026);
    plumb::sim::SweepSettings sweep;
    sweep.motion_distortion = false;
    for (int k = 0; k < 5; ++k) {
      Eigen::Isometry3d T = plan.trajectory.T_world_base(rng.uniform(0.0, plan.frame_stamps.back()));
      T.linear() = Eigen::AngleAxisd(rng.uniform(-M_PI, M_PI), Eigen::Vector3d::UnitZ()).toRotationMatrix();
      const Eigen::Isometry3d T_world_lidar = T * out.T_base_lidar;
      out.frames.push_back(
          plumb::sim::simulate_sweep(*plan.world, s.lidar, [&](double) { return T_world_lidar; }, 0.0, rng, sweep));
      out.truth.push_back(T);
    }
    out.ok = true;
    return out;
  }();
  return d;
}

bool right(const Eigen::Isometry3d& T_world_base, const Eigen::Isometry3d& truth) {
  const Eigen::Isometry3d d = truth.inverse() * T_world_base;
  return d.translation().head<2>().norm() < 0.05 && Eigen::AngleAxisd(d.linear()).angle() < 0.5 * M_PI / 180.0;
}

void bm_plumb_threads(benchmark::State& state, int threads) {
  const Data& d = data();
  if (!d.ok) return state.SkipWithError("AC20-FZK-Haus.ifc missing (PLUMB_DATA_DIR)");
  plumb::BimLocalizerSettings settings;
  settings.threads = threads;
  const plumb::BimLocalizer localizer(*d.mesh, d.bim_cloud, settings);
  std::size_t k = 0, found = 0, runs = 0;
  for (auto _ : state) {
    const plumb::BimLocalization r = localizer.localize(d.frames[k], d.T_base_lidar);
    found += r.status == plumb::Status::kOk && right(r.T_world_base, d.truth[k]) ? 1 : 0;
    ++runs;
    k = (k + 1) % d.frames.size();
  }
  state.counters["found"] = static_cast<double>(found) / static_cast<double>(runs);
}

void bm_plumb(benchmark::State& state) { bm_plumb_threads(state, 1); }

void bm_plumb_sacia_threads(benchmark::State& state, int threads) {
  const Data& d = data();
  if (!d.ok) return state.SkipWithError("AC20-FZK-Haus.ifc missing (PLUMB_DATA_DIR)");
  plumb::LocalizeSettings settings;
  settings.threads = threads;
  const plumb::LocalizeTarget target = plumb::prepare_localize_target(d.bim_cloud, settings);
  std::size_t k = 0, found = 0, runs = 0;
  for (auto _ : state) {
    const plumb::LocalizeResult r = plumb::localize_coarse_to_fine(d.frames[k], target, settings);
    const Eigen::Isometry3d T_world_base = r.T_target_source * d.T_base_lidar.inverse();
    found += r.status == plumb::Status::kOk && right(T_world_base, d.truth[k]) ? 1 : 0;
    ++runs;
    k = (k + 1) % d.frames.size();
  }
  state.counters["found"] = static_cast<double>(found) / static_cast<double>(runs);
}

void bm_plumb_sacia(benchmark::State& state) { bm_plumb_sacia_threads(state, 1); }

#ifdef PLUMB_BENCH_HAVE_OPEN3D
namespace o3g = open3d::geometry;
namespace reg = open3d::pipelines::registration;

std::shared_ptr<o3g::PointCloud> to_open3d(const plumb::PointCloud& c) {
  auto out = std::make_shared<o3g::PointCloud>();
  for (const auto& p : c.points)
    if (p.allFinite()) out->points_.push_back(p.cast<double>());
  return out;
}

void bm_open3d(benchmark::State& state) {
  const Data& d = data();
  if (!d.ok) return state.SkipWithError("AC20-FZK-Haus.ifc missing (PLUMB_DATA_DIR)");
  // The same lengths as plumb's FPFH + SAC-IA chain: 0.3 m coarse voxel, normals 0.6 m, FPFH 1.5 m.
  const double voxel = 0.3;
  auto target = to_open3d(d.bim_cloud)->VoxelDownSample(voxel);
  target->EstimateNormals(o3g::KDTreeSearchParamHybrid(2 * voxel, 30));
  const auto target_fpfh = reg::ComputeFPFHFeature(*target, o3g::KDTreeSearchParamHybrid(5 * voxel, 100));
  auto target_fine = to_open3d(d.bim_cloud)->VoxelDownSample(voxel / 3);
  target_fine->EstimateNormals(o3g::KDTreeSearchParamHybrid(voxel, 30));
  const reg::CorrespondenceCheckerBasedOnEdgeLength edge(0.9);
  const reg::CorrespondenceCheckerBasedOnDistance close(1.5 * voxel);
  const std::vector<std::reference_wrapper<const reg::CorrespondenceChecker>> checkers = {edge, close};
  std::size_t k = 0, found = 0, runs = 0;
  for (auto _ : state) {
    auto source = to_open3d(d.frames[k])->VoxelDownSample(voxel);
    source->EstimateNormals(o3g::KDTreeSearchParamHybrid(2 * voxel, 30));
    source->OrientNormalsTowardsCameraLocation(Eigen::Vector3d::Zero());
    const auto source_fpfh = reg::ComputeFPFHFeature(*source, o3g::KDTreeSearchParamHybrid(5 * voxel, 100));
    const reg::RegistrationResult coarse = reg::RegistrationRANSACBasedOnFeatureMatching(
        *source, *target, *source_fpfh, *target_fpfh, /*mutual_filter=*/false, 1.5 * voxel,
        reg::TransformationEstimationPointToPoint(false), 3, checkers, reg::RANSACConvergenceCriteria(100000, 0.999));
    auto source_fine = to_open3d(d.frames[k])->VoxelDownSample(voxel / 3);
    const reg::RegistrationResult fine = reg::RegistrationICP(*source_fine, *target_fine, voxel, coarse.transformation_,
                                                              reg::TransformationEstimationPointToPlane(),
                                                              reg::ICPConvergenceCriteria(1e-6, 1e-6, 50));
    Eigen::Isometry3d T_bim_lidar;
    T_bim_lidar.matrix() = fine.transformation_;
    found += right(T_bim_lidar * d.T_base_lidar.inverse(), d.truth[k]) ? 1 : 0;
    ++runs;
    k = (k + 1) % d.frames.size();
  }
  state.counters["found"] = static_cast<double>(found) / static_cast<double>(runs);
}
#endif

}  // namespace

int main(int argc, char** argv) {
  plumb::bench::single_thread_openmp();
  benchmark::RegisterBenchmark("bim_localize/plumb/fzk_haus", bm_plumb)->Unit(benchmark::kMillisecond)->Iterations(10);
  // Five iterations, one per frame: every thread count times the same frames.
  for (int threads : {1, 2, 4, 8}) {
    benchmark::RegisterBenchmark(("bim_localize/plumb/fzk_haus/threads:" + std::to_string(threads)).c_str(),
                                 bm_plumb_threads, threads)
        ->Unit(benchmark::kMillisecond)
        ->UseRealTime()
        ->Iterations(5);
  }
  benchmark::RegisterBenchmark("bim_localize/plumb_sacia/fzk_haus", bm_plumb_sacia)
      ->Unit(benchmark::kMillisecond)
      ->Iterations(5);
  plumb::bench::register_threads("bim_localize/plumb_sacia/fzk_haus", bm_plumb_sacia_threads);
#ifdef PLUMB_BENCH_HAVE_OPEN3D
  benchmark::RegisterBenchmark("bim_localize/open3d/fzk_haus", bm_open3d)->Unit(benchmark::kMillisecond)->Iterations(5);
#endif
  return plumb::bench::run_benchmarks(argc, argv);
}
