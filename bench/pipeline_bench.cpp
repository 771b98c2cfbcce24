// SPDX-License-Identifier: BSD-3-Clause
// The BIM-corrected odometry's per-frame loop (the target: ≥ 50 frames/s single thread for 32-line
// frames), timed by itself instead of through `plumb run` (whose frames/s includes reading and
// deskewing the dump).
//
// bim_odometry_frame/plumb/fzk_rfans32: BimOdometry::process on a simulated indoor run in
//   AC20-FZK-Haus (rfans32, the simulator's defaults: as-built deviations, furniture, noise, wheel
//   errors; 12 m of the route, simulated and deskewed with the wheel odometry once before timing),
//   frames in order from the true start pose: 3D -> 2D scan, PLICP front end, ground / vertical key
//   points, their ICP against the BIM cloud, the composer. items_per_second = frames/s.
// bim_odometry_frame/plumb_front_end/fzk_rfans32: the same with use_bim = false (scan, PLICP and
//   the composer only), so the difference is the BIM correction's cost.
// bim_odometry_frame/plumb_as_built/fzk_rfans32: the same with estimate_as_built (every accepted
//   anchor's pairs into the AsBuiltMap, the registration target rebuilt from the elements as
//   estimated every as_built_refresh_every anchors), so the difference is the as-built estimate's cost.
// bim_odometry_frame/plumb_normal_matrix_weights/fzk_rfans32: the same as plumb/ with
//   anchor_from_elements = false (each anchor's information from ICP's normal matrix, scaled, as
//   for a BIM cloud without element labels), so the difference is the cost of weighing anchors by
//   their elements.
// bim_odometry_frame/plumb{,_as_built}/office4_rfans32: the same two loops in a model of four
//   storeys (make_demo_building: 40 x 15 m, 10 rooms a storey; 4.8 million BIM points), 12 m of the
//   ground storey: what a tall model costs. The as-built target is remade from its storey band.
// No peer library implements this pipeline; its ICP is compared with PCL's and Open3D's in
// plumb_registration_bench (icp/*), its kd-tree in plumb_search_bench.
#include <benchmark/benchmark.h>

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <unistd.h>

#include "bench_data.hpp"
#include "plumb/app/simulate.hpp"
#include "plumb/bim/bim_cloud.hpp"
#include "plumb/bim/demo_building.hpp"
#include "plumb/bim/ifc.hpp"
#include "plumb/bim/mesh.hpp"
#include "plumb/core/deskew.hpp"
#include "plumb/io/frame_dump.hpp"
#include "plumb/pipeline/bim_odometry.hpp"
#include "plumb/sim/scenario.hpp"

namespace {

using namespace plumb;

struct IndoorRun {
  std::vector<PointCloud> frames;  // deskewed
  std::vector<double> stamps;
  std::vector<Pose2> odom;
  std::shared_ptr<const PointCloud> bim_cloud;
  Eigen::Isometry3d T0 = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d T_base_lidar = Eigen::Isometry3d::Identity();
};

/// 12 m of the simulator's indoor route through `mesh` (rfans32, its defaults), deskewed.
std::unique_ptr<IndoorRun> indoor_run(const bim::BimMesh& mesh, const std::string& name) {
  auto run = std::make_unique<IndoorRun>();
  const std::string dir = "/tmp/plumb_bench_" + name + "_" + std::to_string(::getpid());
  std::filesystem::remove_all(dir);
  sim::ScenarioSettings s = sim::scenario_defaults(sim::ScenarioKind::kIndoor);
  s.length = 12.0;
  s.seed = 1;
  simulate_to_dump(mesh, dir, s);
  const io::FrameDumpReader dump(dir);
  const OdometryInterpolator odom(dump.odometry());
  run->T_base_lidar = dump.meta().T_base_lidar;
  for (std::size_t i = 0; i < dump.num_frames(); ++i) {
    PointCloud f = dump.frame(i);
    deskew_frame(f, dump.stamp(i), run->T_base_lidar, [&](double t) { return odom.at(t).to_isometry(); });
    run->frames.push_back(std::move(f));
    run->stamps.push_back(dump.stamp(i));
    run->odom.push_back(odom.at(dump.stamp(i)));
  }
  run->T0 = dump.ground_truth().poses.front();
  run->bim_cloud = std::make_shared<PointCloud>(bim::sample_bim_cloud(mesh, 0.05));
  std::filesystem::remove_all(dir);
  return run;
}

const IndoorRun& fzk_indoor() {
  static const std::unique_ptr<IndoorRun> run =
      indoor_run(bim::build_mesh(bim::read_ifc(bench::data_path("ifc/buildings/AC20-FZK-Haus.ifc"))), "fzk_indoor");
  return *run;
}

const IndoorRun& office4_indoor() {
  static const std::unique_ptr<IndoorRun> run = [] {
    bim::DemoBuildingSettings b;
    b.length = 40.0;
    b.num_rooms = 10;
    b.num_storeys = 4;
    return indoor_run(bim::build_mesh(bim::parse_ifc(bim::make_demo_building(b).ifc, "office4.ifc")), "office4");
  }();
  return *run;
}

void BM_BimOdometryFrame(benchmark::State& state, bool use_bim, bool as_built, int threads = 1,
                         bool from_elements = true, bool office4 = false) {
  const IndoorRun& run = office4 ? office4_indoor() : fzk_indoor();
  BimOdometrySettings s;
  s.T_base_lidar = run.T_base_lidar;
  s.threads = threads;
  s.use_bim = use_bim;
  s.estimate_as_built = as_built;
  s.anchor_from_elements = from_elements;
  std::unique_ptr<BimOdometry> odometry;
  std::size_t anchors = 0;
  auto restart = [&] { odometry = std::make_unique<BimOdometry>(use_bim ? run.bim_cloud : nullptr, run.T0, s); };
  restart();
  const std::size_t frames = bench::time_frames_in_order(state, 0, run.frames.size(), restart, [&](std::size_t i) {
    const BimFrameResult r = odometry->process(run.frames[i], run.stamps[i], run.odom[i]);
    benchmark::DoNotOptimize(r.T_world_base.data());
    anchors += r.anchor.decision == AnchorDecision::kAccepted ? 1 : 0;
  });
  state.counters["points_per_frame"] = static_cast<double>(run.frames.back().size());
  state.counters["bim_points"] = static_cast<double>(run.bim_cloud->size());
  if (use_bim && frames > 0) state.counters["anchors_accepted_per_frame"] = static_cast<double>(anchors) / frames;
}

// Threads within a frame: key points beside the front end, the registration's search split. (plumb
// run also overlaps frames, which this frame-by-frame loop does not.)
void BM_BimOdometryFrameThreads(benchmark::State& state, int threads) { BM_BimOdometryFrame(state, true, false, threads); }
const bool kThreadsRegistered =
    (bench::register_threads("bim_odometry_frame/plumb/fzk_rfans32", BM_BimOdometryFrameThreads), true);

}  // namespace

BENCHMARK_CAPTURE(BM_BimOdometryFrame, fzk, true, false)->Name("bim_odometry_frame/plumb/fzk_rfans32")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_BimOdometryFrame, fzk_as_built, true, true)
    ->Name("bim_odometry_frame/plumb_as_built/fzk_rfans32")
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_BimOdometryFrame, fzk_normal_matrix_weights, true, false, 1, false)
    ->Name("bim_odometry_frame/plumb_normal_matrix_weights/fzk_rfans32")
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_BimOdometryFrame, fzk_front_end, false, false)
    ->Name("bim_odometry_frame/plumb_front_end/fzk_rfans32")
    ->Unit(benchmark::kMillisecond);

BENCHMARK_CAPTURE(BM_BimOdometryFrame, office4, true, false, 1, true, true)
    ->Name("bim_odometry_frame/plumb/office4_rfans32")
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_BimOdometryFrame, office4_as_built, true, true, 1, true, true)
    ->Name("bim_odometry_frame/plumb_as_built/office4_rfans32")
    ->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
