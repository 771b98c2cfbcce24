// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/sim/route.hpp"

#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "plumb/bim/ifc.hpp"
#include "plumb/core/error.hpp"
#include "plumb/core/rng.hpp"
#include "plumb/sim/robot.hpp"
#include "test_data.hpp"

namespace plumb::sim {
namespace {

using bim::CellState;
using bim::OccupancyGrid;

/// 12 x 8 m, walls 0.2 m, three rooms: left (x < 6), lower right, upper right; 1 m doorways.
OccupancyGrid three_rooms(double res = 0.05) {
  OccupancyGrid g;
  g.resolution = res;
  g.origin = Vector2d(-0.5, -0.5);
  g.width = static_cast<int>(std::lround(13.0 / res));
  g.height = static_cast<int>(std::lround(9.0 / res));
  g.cells.assign(static_cast<std::size_t>(g.width) * g.height, CellState::kOutside);
  for (int iy = 0; iy < g.height; ++iy) {
    for (int ix = 0; ix < g.width; ++ix) {
      const Vector2d p = g.center(ix, iy);
      if (p.x() < 0 || p.x() > 12 || p.y() < 0 || p.y() > 8) continue;
      bool wall = p.x() < 0.2 || p.x() > 11.8 || p.y() < 0.2 || p.y() > 7.8;
      wall |= std::abs(p.x() - 6.0) < 0.1 && !(p.y() > 3 && p.y() < 4);
      wall |= p.x() > 6.0 && std::abs(p.y() - 4.0) < 0.1 && !(p.x() > 8.5 && p.x() < 9.5);
      g.cells[g.index(ix, iy)] = wall ? CellState::kOccupied : CellState::kFree;
    }
  }
  return g;
}

int room_of(const Vector2d& p) {
  if (p.x() < 6.0) return 0;
  return p.y() < 4.0 ? 1 : 2;
}

TEST(RouteTest, ClearanceMatchesBruteForce) {
  Rng rng(3);
  OccupancyGrid g;
  g.resolution = 0.1;
  g.width = 37;
  g.height = 23;
  for (int i = 0; i < g.width * g.height; ++i) {
    g.cells.push_back(rng.uniform() < 0.08 ? CellState::kOccupied : CellState::kFree);
  }
  const std::vector<float> clr = clearance_map(g);
  for (int iy = 0; iy < g.height; ++iy) {
    for (int ix = 0; ix < g.width; ++ix) {
      double best = std::numeric_limits<double>::infinity();
      for (int jy = 0; jy < g.height; ++jy)
        for (int jx = 0; jx < g.width; ++jx)
          if (g.at(jx, jy) != CellState::kFree) best = std::min(best, std::hypot(ix - jx, iy - jy) * g.resolution);
      ASSERT_NEAR(clr[g.index(ix, iy)], best, 1e-5) << ix << "," << iy;
    }
  }
  OccupancyGrid open = g;
  std::fill(open.cells.begin(), open.cells.end(), CellState::kFree);
  EXPECT_GT(clearance_map(open)[0], 1e3);  // no obstacle anywhere
}

TEST(RouteTest, PathKeepsClearanceAndConnectsRooms) {
  const OccupancyGrid g = three_rooms();
  const std::vector<float> clr = clearance_map(g);
  RouteSettings s;
  const std::vector<Vector2d> path = plan_path(g, clr, {2, 2}, {10, 6}, s);
  ASSERT_GE(path.size(), 3u);
  EXPECT_EQ(path.front(), Vector2d(2, 2));
  EXPECT_EQ(path.back(), Vector2d(10, 6));
  for (std::size_t i = 1; i < path.size(); ++i) {
    for (int k = 0; k <= 100; ++k) {
      const Vector2d p = path[i - 1] + (path[i] - path[i - 1]) * (k / 100.0);
      const Eigen::Vector2i c = g.cell_of(p);
      ASSERT_GE(clr[g.index(c.x(), c.y())], s.min_clearance - 1e-6) << p.transpose();
    }
  }
  // Through both doorways: no shorter than the straight line, not absurdly long.
  const double len = polyline_length(path, false);
  EXPECT_GT(len, (Vector2d(10, 6) - Vector2d(2, 2)).norm());
  EXPECT_LT(len, 16.0);
  EXPECT_THROW(plan_path(g, clr, {0.1, 2}, {10, 6}, s), Error);   // start in the wall
  EXPECT_THROW(plan_path(g, clr, {2, 2}, {50, 6}, s), Error);     // goal outside the grid
}

TEST(RouteTest, AutoRouteVisitsEveryRoomInFreeSpace) {
  const OccupancyGrid g = three_rooms();
  RouteSettings s;
  const Route route = plan_auto_route(g, s);
  ASSERT_GE(route.waypoints.size(), 3u);
  bool rooms[3] = {false, false, false};
  for (const Vector2d& w : route.waypoints) rooms[room_of(w)] = true;
  EXPECT_TRUE(rooms[0] && rooms[1] && rooms[2]);
  EXPECT_NEAR(route.length, polyline_length(route.points, true), 1e-9);
  // Driven twice by the robot: every true position stays in free space, clear of the walls.
  const RobotTrajectory traj = drive_route(route.points, true, 2, 0.0, 0.0);
  const std::vector<float> clr = clearance_map(g);
  double min_clr = 1e9;
  for (std::size_t k = 0; k < traj.states.size(); k += 10) {
    const Vector2d p(traj.states[k].pose.x, traj.states[k].pose.y);
    ASSERT_TRUE(g.is_free(p)) << p.transpose();
    const Eigen::Vector2i c = g.cell_of(p);
    min_clr = std::min(min_clr, static_cast<double>(clr[g.index(c.x(), c.y())]));
  }
  EXPECT_GT(min_clr, 0.2);
  EXPECT_NEAR(traj.length(), 2.0 * route.length, 0.1 * route.length);
  // Deterministic.
  const Route again = plan_auto_route(g, s);
  EXPECT_EQ(again.points, route.points);
}

TEST(RouteTest, TooNarrowSpaceIsAnError) {
  OccupancyGrid g;
  g.resolution = 0.1;
  g.width = 50;
  g.height = 5;
  g.cells.assign(250, CellState::kOccupied);
  for (int ix = 1; ix < 49; ++ix) g.cells[g.index(ix, 2)] = CellState::kFree;  // a 10 cm corridor
  EXPECT_THROW(plan_auto_route(g), Error);
}

TEST(RouteTest, FzkHausAutoRouteStaysInFreeSpace) {
  PLUMB_REQUIRE_DATA(path, "ifc/buildings/AC20-FZK-Haus.ifc");
  const bim::BimMesh mesh = bim::build_mesh(bim::read_ifc(path));
  const OccupancyGrid g = bim::floor_plan(mesh);
  const Route route = plan_auto_route(g);
  EXPECT_GE(route.waypoints.size(), 3u);
  EXPECT_GT(route.length, 10.0);
  const RobotTrajectory traj = drive_route(route.points, true, 1, 0.0, g.floor_z);
  for (std::size_t k = 0; k < traj.states.size(); k += 20) {
    ASSERT_TRUE(g.is_free({traj.states[k].pose.x, traj.states[k].pose.y})) << "state " << k;
  }
}

}  // namespace
}  // namespace plumb::sim
