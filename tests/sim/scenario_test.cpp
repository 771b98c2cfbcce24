// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/sim/scenario.hpp"

#include <algorithm>
#include <cmath>

#include <gtest/gtest.h>

#include "plumb/bim/floor_plan.hpp"
#include "plumb/bim/ifc.hpp"
#include "plumb/core/error.hpp"
#include "model_variants.hpp"
#include "test_data.hpp"

namespace plumb::sim {
namespace {

/// The frames a simulation hands out, kept (the tests' runs are short).
struct Frames {
  std::vector<double> stamps;
  std::vector<PointCloud> clouds;
  ScenarioFrameSink sink() {
    return [this](std::size_t index, double stamp, const PointCloud& cloud) {
      EXPECT_EQ(index, stamps.size());
      stamps.push_back(stamp);
      clouds.push_back(cloud);
    };
  }
};

bool same_cloud(const PointCloud& a, const PointCloud& b) {
  return a.points == b.points && a.intensities == b.intensities && a.rings == b.rings && a.times == b.times &&
         a.labels == b.labels;
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

TEST(ScenarioTest, IndoorSimulationIsConsistent) {
  PLUMB_REQUIRE_DATA(path, "ifc/buildings/AC20-FZK-Haus.ifc");
  const ScenarioSettings s = small_indoor(4.0);
  Frames frames;
  const ScenarioRecording r = simulate_scenario(fzk_haus(), s, frames.sink());
  EXPECT_GT(r.summary.num_frames, 40u);
  EXPECT_NEAR(r.summary.path_length, 4.0, 0.6);  // 4 m along the route; corners are cut
  ASSERT_EQ(frames.clouds.size(), r.summary.num_frames);
  std::size_t points = 0;
  for (const PointCloud& c : frames.clouds) points += c.size();
  EXPECT_EQ(points, r.summary.num_points);

  // Ground truth at the frame stamps, frames 1 / rate apart.
  const Trajectory& gt = r.ground_truth;
  ASSERT_EQ(gt.size(), frames.stamps.size());
  for (std::size_t i = 0; i < gt.size(); ++i) EXPECT_EQ(gt.stamps[i], frames.stamps[i]);
  EXPECT_NEAR(frames.stamps[1] - frames.stamps[0], 0.1, 1e-12);
  // IMU at 200 Hz and wheels at 50 Hz over the whole run.
  const Trajectory& dense = r.ground_truth_dense;
  const double span = dense.stamps.back() - dense.stamps.front();
  EXPECT_NEAR(static_cast<double>(r.imu.size()), span * 200.0 + 1.0, 1.0);
  EXPECT_NEAR(static_cast<double>(r.wheels.size()), span * 50.0 + 1.0, 1.0);
  // The odometry is the wheels integrated with the nominal parameters.
  const auto again = integrate_wheel_odometry(r.wheels, s.wheels.radius, s.wheels.radius, s.wheels.axle);
  ASSERT_EQ(r.odometry.size(), again.size());
  EXPECT_EQ(r.odometry.back().pose.x, again.back().pose.x);
  EXPECT_EQ(r.odometry.back().pose.theta, again.back().pose.theta);
  // Every frame: fields present; points on the ground, carried into the world by the true pose at
  // their own time, lie on the floor of the storey.
  std::vector<double> floor_dz;
  for (std::size_t i = 0; i < frames.clouds.size(); i += 7) {
    const PointCloud& c = frames.clouds[i];
    ASSERT_FALSE(c.empty());
    ASSERT_TRUE(c.has_rings() && c.has_times() && c.has_labels() && c.has_intensities());
    for (std::size_t k = 0; k < c.size(); ++k) {
      ASSERT_GE(c.times[k], 0.0f);
      ASSERT_LT(c.times[k], 0.1f);
      ASSERT_LT(c.rings[k], 8);
      if (c.labels[k] != kSimGround) continue;
      const double t = frames.stamps[i] + c.times[k];
      const auto it = std::lower_bound(dense.stamps.begin(), dense.stamps.end(), t);
      const std::size_t j = static_cast<std::size_t>(std::min<std::ptrdiff_t>(
          it - dense.stamps.begin(), static_cast<std::ptrdiff_t>(dense.size()) - 1));
      const Vector3d p_world = dense.poses[j] * s.T_base_lidar * c.points[k].cast<double>();
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
  Frames a, b, c;
  const ScenarioRecording ra = simulate_scenario(fzk_haus(), s, a.sink());
  s.num_threads = 2;
  const ScenarioRecording rb = simulate_scenario(fzk_haus(), s, b.sink());
  ASSERT_EQ(a.clouds.size(), b.clouds.size());
  EXPECT_EQ(a.stamps, b.stamps);
  for (std::size_t i = 0; i < a.clouds.size(); ++i) EXPECT_TRUE(same_cloud(a.clouds[i], b.clouds[i])) << i;
  ASSERT_EQ(ra.imu.size(), rb.imu.size());
  for (std::size_t i = 0; i < ra.imu.size(); ++i) {
    ASSERT_TRUE(ra.imu[i].stamp == rb.imu[i].stamp && ra.imu[i].gyro == rb.imu[i].gyro &&
                ra.imu[i].accel == rb.imu[i].accel) << i;
  }
  ASSERT_EQ(ra.wheels.size(), rb.wheels.size());
  for (std::size_t i = 0; i < ra.wheels.size(); ++i) {
    ASSERT_TRUE(ra.wheels[i].stamp == rb.wheels[i].stamp && ra.wheels[i].left == rb.wheels[i].left &&
                ra.wheels[i].right == rb.wheels[i].right) << i;
  }
  s.seed = 6;
  const ScenarioRecording rc = simulate_scenario(fzk_haus(), s, c.sink());
  ASSERT_EQ(rc.imu.size(), ra.imu.size());
  EXPECT_NE(ra.imu[10].gyro, rc.imu[10].gyro);
  ASSERT_GT(c.clouds.size(), 3u);
  EXPECT_FALSE(same_cloud(a.clouds[3], c.clouds[3]));
}

// The frames are handed out one at a time: an exception from the sink ends the simulation there.
TEST(ScenarioTest, AnExceptionFromTheSinkEndsTheSimulation) {
  PLUMB_REQUIRE_DATA(path, "ifc/buildings/AC20-FZK-Haus.ifc");
  std::size_t calls = 0;
  EXPECT_THROW(simulate_scenario(fzk_haus(), small_indoor(1.5),
                                 [&](std::size_t index, double, const PointCloud&) {
                                   ++calls;
                                   if (index == 2) throw Error("stop");
                                 }),
               Error);
  EXPECT_EQ(calls, 3u);
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
    simulate_scenario(mesh, small_indoor(1.0), ScenarioFrameSink());
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
