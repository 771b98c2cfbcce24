// SPDX-License-Identifier: BSD-3-Clause
// run_bim_odometry with the as-built estimate in a four-storey building: the registration target
// remade from the estimate is the storey band the robot drives in, and every frame's result (the
// estimate's included) is bit for bit the one against the whole model, and the one with the band
// moved and refitted on several threads.
#include <filesystem>
#include <limits>
#include <string>

#include <unistd.h>

#include <gtest/gtest.h>

#include "plumb/app/run.hpp"
#include "plumb/app/simulate.hpp"
#include "plumb/bim/bim_cloud.hpp"
#include "plumb/bim/demo_building.hpp"
#include "plumb/bim/ifc.hpp"
#include "plumb/bim/mesh.hpp"
#include "plumb/io/frame_dump.hpp"
#include "plumb/sim/scenario.hpp"
#include "test_data.hpp"

namespace {

TEST(RunStoreyBandTest, ADisplacedTargetIsTheStoreyBandAndChangesNoResult) {
  plumb::bim::DemoBuildingSettings b;
  b.length = 20.0;
  b.width = 12.0;
  b.num_rooms = 5;
  b.num_storeys = 4;
  const plumb::bim::BimMesh mesh =
      plumb::bim::build_mesh(plumb::bim::parse_ifc(plumb::bim::make_demo_building(b).ifc, "four_storeys.ifc"));
  const std::string dir = plumb::test::temp_path("band_dump_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  plumb::sim::ScenarioSettings s = plumb::sim::scenario_defaults(plumb::sim::ScenarioKind::kIndoor);
  s.lidar = plumb::sim::lidar_preset("vlp16");
  s.length = 6.0;
  s.seed = 2;
  s.storey = 0;
  plumb::simulate_to_dump(mesh, dir, s);
  const plumb::io::FrameDumpReader dump(dir);

  auto run = [&](double band_margin, int refresh_threads) {
    plumb::RunSettings settings;
    settings.initial_pose = dump.ground_truth().poses.front();
    settings.odometry.estimate_as_built = true;
    settings.odometry.as_built_refresh_every = 3;
    settings.odometry.target_band_margin = band_margin;
    settings.odometry.refresh_threads = refresh_threads;
    return plumb::run_bim_odometry(dump, mesh, settings);
  };
  const plumb::RunReport band = run(0.5, 1);
  const plumb::RunReport whole = run(std::numeric_limits<double>::infinity(), 1);
  // The band moved and refitted on three threads: every frame as on one.
  const plumb::RunReport threaded = run(0.5, 3);
  std::filesystem::remove_all(dir);
  ASSERT_EQ(threaded.frames.size(), band.frames.size());
  for (std::size_t i = 0; i < band.frames.size(); ++i) {
    ASSERT_TRUE(threaded.frames[i].T_world_base.matrix() == band.frames[i].T_world_base.matrix()) << "frame " << i;
    ASSERT_EQ(threaded.frames[i].icp_inliers, band.frames[i].icp_inliers) << "frame " << i;
    ASSERT_EQ(threaded.frames[i].target_points, band.frames[i].target_points) << "frame " << i;
  }

  ASSERT_EQ(band.frames.size(), whole.frames.size());
  ASSERT_GT(band.anchors_accepted, 20u);
  std::size_t banded = 0;
  for (std::size_t i = 0; i < band.frames.size(); ++i) {
    const plumb::BimFrameResult& a = band.frames[i];
    const plumb::BimFrameResult& w = whole.frames[i];
    ASSERT_TRUE(a.T_world_base.matrix() == w.T_world_base.matrix()) << "frame " << i;
    ASSERT_TRUE(a.T_world_base_registered.matrix() == w.T_world_base_registered.matrix()) << i;
    ASSERT_EQ(a.icp_inliers, w.icp_inliers) << i;
    ASSERT_EQ(a.as_built_pairs, w.as_built_pairs) << i;
    if (!a.anchor_attempted) continue;
    ASSERT_EQ(w.target_points, band.bim_points) << i;
    ASSERT_LE(a.target_points, band.bim_points) << i;
    // Once the target is displaced it is the band: the ground storey and parts of the slab and
    // walls above, fewer points than two of the four storeys have.
    if (a.target_points < band.bim_points / 2) ++banded;
  }
  EXPECT_GT(banded, band.frames.size() / 2);
  ASSERT_EQ(band.deviations.size(), whole.deviations.size());
  for (std::size_t k = 0; k < band.deviations.size(); ++k) {
    EXPECT_EQ(band.deviations[k].offset_m, whole.deviations[k].offset_m) << band.deviations[k].global_id;
    EXPECT_EQ(band.deviations[k].sigma_m, whole.deviations[k].sigma_m) << band.deviations[k].global_id;
  }
  std::size_t observed = 0;
  for (const plumb::DeviationReportRow& d : band.deviations) observed += d.observations > 0 ? 1 : 0;
  EXPECT_GT(observed, 5u);
}

}  // namespace
