// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/sim/scenario.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>

#include <gtest/gtest.h>

#include "plumb/bim/floor_plan.hpp"
#include "plumb/bim/ifc.hpp"
#include "plumb/core/error.hpp"
#include "plumb/io/frame_dump.hpp"
#include "model_variants.hpp"
#include "test_data.hpp"

namespace plumb::sim {
namespace {

namespace fs = std::filesystem;

std::string fresh_dir(const std::string& name) {
  const std::string dir = test::temp_path("scenario_" + name);
  fs::remove_all(dir);
  return dir;
}

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

/// A coarse 8-line LiDAR (720 rays per sweep) so the tests stay fast.
LidarModel coarse_lidar() {
  LidarModel m = lidar_preset("rfans32");
  m.name = "coarse8";
  m.elevations_rad.clear();
  for (int r = 0; r < 8; ++r) m.elevations_rad.push_back((-20.0 + 4.0 * r) * 3.14159265358979 / 180.0);
  m.columns = 90;
  return m;
}

const bim::BimMesh& fzk_haus() {
  static const bim::BimMesh mesh = bim::build_mesh(bim::read_ifc(test::data_path("ifc/buildings/AC20-FZK-Haus.ifc")));
  return mesh;
}

ScenarioSettings small_indoor(double length) {
  ScenarioSettings s = scenario_defaults(ScenarioKind::kIndoor);
  s.lidar = coarse_lidar();
  s.loops = 1;
  s.length = length;
  s.seed = 5;
  return s;
}

TEST(ScenarioTest, IndoorDumpIsConsistent) {
  PLUMB_REQUIRE_DATA(path, "ifc/buildings/AC20-FZK-Haus.ifc");
  const std::string dir = fresh_dir("indoor");
  const ScenarioSettings s = small_indoor(4.0);
  const ScenarioResult r = simulate_scenario(fzk_haus(), dir, s);
  EXPECT_GT(r.num_frames, 40u);
  EXPECT_NEAR(r.path_length, 4.0, 0.6);  // 4 m along the route; corners are cut

  const io::FrameDumpReader dump(dir);
  ASSERT_EQ(dump.num_frames(), r.num_frames);
  EXPECT_EQ(dump.meta().lidar.name, "coarse8");
  EXPECT_TRUE(dump.meta().T_base_lidar.isApprox(s.T_base_lidar));
  EXPECT_EQ(dump.meta().scenario, "indoor");
  // gt.tum at the frame stamps, frames 1 / rate apart.
  const Trajectory gt = dump.ground_truth();
  ASSERT_EQ(gt.size(), dump.num_frames());
  for (std::size_t i = 0; i < gt.size(); ++i) EXPECT_EQ(gt.stamps[i], dump.stamp(i));
  EXPECT_NEAR(dump.stamp(1) - dump.stamp(0), 0.1, 1e-12);
  // IMU at 200 Hz and wheels at 50 Hz over the whole run.
  const Trajectory dense = dump.ground_truth_dense();
  const double span = dense.stamps.back() - dense.stamps.front();
  EXPECT_NEAR(static_cast<double>(dump.imu().size()), span * 200.0 + 1.0, 1.0);
  const auto wheels = dump.wheels();
  EXPECT_NEAR(static_cast<double>(wheels.size()), span * 50.0 + 1.0, 1.0);
  // odom.csv is the wheels integrated with the nominal parameters of meta.json.
  const auto odom = dump.odometry();
  const auto again = integrate_wheel_odometry(wheels, dump.meta().wheel_radius_left, dump.meta().wheel_radius_right,
                                              dump.meta().axle);
  ASSERT_EQ(odom.size(), again.size());
  EXPECT_NEAR(odom.back().pose.x, again.back().pose.x, 1e-12);
  EXPECT_NEAR(odom.back().pose.theta, again.back().pose.theta, 1e-12);
  // Every frame: fields present; points on the ground, carried into the world by the true pose at
  // their own time, lie on the floor of the storey.
  std::vector<double> floor_dz;
  for (std::size_t i = 0; i < dump.num_frames(); i += 7) {
    const PointCloud c = dump.frame(i);
    ASSERT_FALSE(c.empty());
    ASSERT_TRUE(c.has_rings() && c.has_times() && c.has_labels() && c.has_intensities());
    for (std::size_t k = 0; k < c.size(); ++k) {
      ASSERT_GE(c.times[k], 0.0f);
      ASSERT_LT(c.times[k], 0.1f);
      ASSERT_LT(c.rings[k], 8);
      if (c.labels[k] != kSimGround) continue;
      const double t = dump.stamp(i) + c.times[k];
      const auto it = std::lower_bound(dense.stamps.begin(), dense.stamps.end(), t);
      const std::size_t j = static_cast<std::size_t>(std::min<std::ptrdiff_t>(
          it - dense.stamps.begin(), static_cast<std::ptrdiff_t>(dense.size()) - 1));
      const Vector3d p_world = dense.poses[j] * dump.meta().T_base_lidar * c.points[k].cast<double>();
      floor_dz.push_back(std::abs(p_world.z() - dense.poses[0].translation().z()));
    }
  }
  ASSERT_GT(floor_dz.size(), 50u);
  std::nth_element(floor_dz.begin(), floor_dz.begin() + floor_dz.size() / 2, floor_dz.end());
  EXPECT_LT(floor_dz[floor_dz.size() / 2], 0.05);
}

TEST(ScenarioTest, DeterministicForASeedWhateverTheThreads) {
  PLUMB_REQUIRE_DATA(path, "ifc/buildings/AC20-FZK-Haus.ifc");
  ScenarioSettings s = small_indoor(1.5);
  const std::string a = fresh_dir("seed_a"), b = fresh_dir("seed_b"), c = fresh_dir("seed_c");
  simulate_scenario(fzk_haus(), a, s);
  s.num_threads = 2;
  simulate_scenario(fzk_haus(), b, s);
  for (const char* f : {"frames.csv", "imu.csv", "wheels.csv", "odom.csv", "gt.tum", "frames/000003.pcd"}) {
    EXPECT_EQ(slurp(a + "/" + f), slurp(b + "/" + f)) << f;
  }
  s.seed = 6;
  simulate_scenario(fzk_haus(), c, s);
  EXPECT_NE(slurp(a + "/imu.csv"), slurp(c + "/imu.csv"));
  EXPECT_NE(slurp(a + "/frames/000003.pcd"), slurp(c + "/frames/000003.pcd"));
}

TEST(ScenarioTest, IndoorRouteStaysInFreeSpaceAroundClutter) {
  PLUMB_REQUIRE_DATA(path, "ifc/buildings/AC20-FZK-Haus.ifc");
  const ScenarioPlan plan = plan_scenario(fzk_haus(), small_indoor(0.0));
  // The grid holds the clutter the World placed; the robot never enters a non-free cell.
  for (std::size_t k = 0; k < plan.trajectory.states.size(); k += 25) {
    const RobotState& st = plan.trajectory.states[k];
    ASSERT_TRUE(plan.grid.is_free({st.pose.x, st.pose.y})) << "t = " << st.t;
  }
  EXPECT_GE(plan.route.waypoints.size(), 3u);
  EXPECT_EQ(plan.storey, plan.grid.storey);
  EXPECT_EQ(plan.floor_z, fzk_haus().storeys[static_cast<std::size_t>(plan.storey)].elevation);
}

TEST(ScenarioTest, SiteDrivesAroundTheBuildingOnOpenGround) {
  PLUMB_REQUIRE_DATA(path, "ifc/buildings/AC20-FZK-Haus.ifc");
  const ScenarioSettings s = scenario_defaults(ScenarioKind::kSite);
  EXPECT_EQ(s.lidar.elevations_rad.size(), 16u);
  EXPECT_EQ(s.imu.rate_hz, 300.0);
  const ScenarioPlan plan = plan_scenario(fzk_haus(), s);
  EXPECT_GE(plan.trajectory.length(), 0.97 * s.site_min_length);
  EXPECT_GE(plan.route.length * s.loops, s.site_min_length);
  Vector3d lo, hi;
  fzk_haus().bounds(lo, hi);
  double max_distance = 0.0;
  for (std::size_t k = 0; k < plan.trajectory.states.size(); k += 100) {
    const Vector2d p(plan.trajectory.states[k].pose.x, plan.trajectory.states[k].pose.y);
    const bool inside = p.x() > lo.x() - 1.0 && p.x() < hi.x() + 1.0 && p.y() > lo.y() - 1.0 && p.y() < hi.y() + 1.0;
    ASSERT_FALSE(inside) << "the site route enters the building at " << p.transpose();
    max_distance = std::max(max_distance, p.x() - hi.x());
  }
  EXPECT_GT(max_distance, s.site_excursion);  // a long stretch far from any wall
  // One sweep from the start: most returns come from the ground the scenario added.
  Rng rng(1);
  LidarModel lidar = s.lidar;
  lidar.columns = 360;
  const Eigen::Isometry3d T = plan.trajectory.T_world_base(plan.frame_stamps[0]) * s.T_base_lidar;
  const PointCloud c = simulate_sweep(*plan.world, lidar, [&](double) { return T; }, plan.frame_stamps[0], rng);
  const auto ground = std::count(c.labels.begin(), c.labels.end(), kSimGround);
  EXPECT_GT(static_cast<double>(ground), 0.3 * static_cast<double>(c.size()));
}

// FZK-Haus as an architectural export without its slabs and coverings (the floors left to the
// structural model): the route is planned on the floor its walls enclose and stays on the floor
// of the full model (the independent reference), and the world the LiDAR sees has no floor.
TEST(ScenarioTest, IndoorRouteInAModelWithoutFloorsStaysOnTheRealFloor) {
  PLUMB_REQUIRE_DATA(path, "ifc/buildings/AC20-FZK-Haus.ifc");
  const bim::BimMesh bare = test::without_types(fzk_haus(), {"IfcSlab", "IfcCovering"});
  const ScenarioPlan plan = plan_scenario(bare, small_indoor(0.0));
  EXPECT_EQ(plan.grid.floor_source, bim::FloorSource::kWalls);
  EXPECT_EQ(plan.storey, 0);
  EXPECT_GT(plan.route.length, 15.0);
  EXPECT_GE(plan.route.waypoints.size(), 3u);
  const bim::OccupancyGrid real = bim::floor_plan(fzk_haus());
  for (std::size_t k = 0; k < plan.trajectory.states.size(); k += 10) {
    const RobotState& st = plan.trajectory.states[k];
    ASSERT_TRUE(real.is_free({st.pose.x, st.pose.y})) << "t = " << st.t;
  }
}

// The same export with its rooms (IfcSpace) kept: the rooms make the floor, the route stays on
// the full model's floor, and the world the LiDAR sees is the one of the model without rooms.
TEST(ScenarioTest, IndoorRouteInAModelWithRoomsButNoFloorsStaysOnTheRealFloor) {
  PLUMB_REQUIRE_DATA(path, "ifc/buildings/AC20-FZK-Haus.ifc");
  const bim::BimMesh with_rooms = bim::build_mesh(bim::read_ifc(path), bim::mesh_settings_with_spaces());
  const bim::BimMesh bare = test::without_types(with_rooms, {"IfcSlab", "IfcCovering"});
  ScenarioSettings s = small_indoor(0.0);
  s.storey = 0;  // both storeys have rooms; the ground floor is the one the full model drives
  const ScenarioPlan plan = plan_scenario(bare, s);
  EXPECT_EQ(plan.grid.floor_source, bim::FloorSource::kSpaces);
  EXPECT_GT(plan.route.length, 15.0);
  const bim::OccupancyGrid real = bim::floor_plan(fzk_haus());
  for (std::size_t k = 0; k < plan.trajectory.states.size(); k += 10) {
    const RobotState& st = plan.trajectory.states[k];
    ASSERT_TRUE(real.is_free({st.pose.x, st.pose.y})) << "t = " << st.t;
  }
}

// A route that cannot be made is an error naming why, not a route of 0 m.
TEST(ScenarioTest, ARouteTooShortIsAnError) {
  bim::OccupancyGrid g;
  g.resolution = 0.05;
  g.width = 40;
  g.height = 40;
  g.cells.assign(1600, bim::CellState::kOutside);
  for (int iy = 13; iy < 27; ++iy) {
    for (int ix = 13; ix < 27; ++ix) g.cells[g.index(ix, iy)] = bim::CellState::kFree;  // 0.7 m square
  }
  RouteSettings rs;
  rs.min_clearance = 0.2;
  rs.min_waypoint_clearance = 0.2;
  try {
    plan_auto_route(g, rs);
    FAIL() << "expected plumb::Error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("too small or too narrow"), std::string::npos) << e.what();
  }
  rs.min_length = 0.0;
  EXPECT_NO_THROW(plan_auto_route(g, rs));
}

TEST(ScenarioTest, ModelWithoutWalkableStoreyIsAClearError) {
  PLUMB_REQUIRE_DATA(path, "ifc/unit/basic_shape_SweptSolid.ifc");
  const bim::BimMesh mesh = bim::build_mesh(bim::read_ifc(path));
  try {
    simulate_scenario(mesh, fresh_dir("no_storey"), small_indoor(1.0));
    FAIL() << "expected plumb::Error";
  } catch (const Error& e) {
    const std::string msg = e.what();
    EXPECT_TRUE(msg.find("walkable") != std::string::npos || msg.find("no storey") != std::string::npos) << msg;
  }
  EXPECT_THROW(scenario_kind_from_string("outdoor"), Error);
  ScenarioSettings bad = small_indoor(1.0);
  bad.loops = 0;
  EXPECT_THROW(plan_scenario(fzk_haus(), bad), Error);
}

}  // namespace
}  // namespace plumb::sim
