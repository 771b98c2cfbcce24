// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Routes for the simulated robot: clearance map, A* with clearance over an occupancy grid,
///        and the `auto` route (a loop through the free space of a storey visiting several rooms).

#include <cstdint>
#include <vector>

#include "plumb/bim/floor_plan.hpp"
#include "plumb/core/types.hpp"

namespace plumb::sim {

/// @brief Euclidean distance of every cell centre to the nearest cell that is not free [m]
///        (exact distance transform, Felzenszwalb & Huttenlocher 2012); 0 on non-free cells.
std::vector<float> clearance_map(const bim::OccupancyGrid& grid);

/// @brief Settings of plan_path() and plan_auto_route().
struct RouteSettings {
  double min_clearance = 0.35;        ///< cells nearer than this to a non-free cell are never driven [m]
  double preferred_clearance = 0.8;   ///< A* adds cost for cells with less clearance than this [m]
  double clearance_weight = 4.0;      ///< extra cost factor at zero clearance margin (dimensionless)
  int max_waypoints = 8;              ///< places (room centres) visited per loop
  double min_waypoint_clearance = 0.6;     ///< a waypoint has at least this clearance [m]
  double min_waypoint_separation = 2.5;    ///< waypoints are at least this far apart [m]
  double min_length = 1.0;            ///< a shorter closed route is an error, not a route [m]
};

/// @brief A closed route: the robot starts at points[0] and returns there after the last point.
struct Route {
  std::vector<Vector2d> points;     ///< polyline vertices [m], closing segment implied
  std::vector<Vector2d> waypoints;  ///< the places visited, in visiting order [m]
  double length = 0.0;              ///< length of the closed polyline [m]
};

/// @brief Shortest path (8-connected A*, clearance-weighted) between two points, shortened by
///        line-of-sight shortcuts that keep the clearance of the original path.
/// @param clearance from clearance_map(grid).
/// @return the polyline from start to goal; empty when the goal cannot be reached.
/// @throws plumb::Error when start or goal are outside the grid or closer than min_clearance to an obstacle.
std::vector<Vector2d> plan_path(const bim::OccupancyGrid& grid, const std::vector<float>& clearance,
                                const Vector2d& start, const Vector2d& goal, const RouteSettings& settings = {});

/// @brief The `auto` route: waypoints at clearance maxima (room centres first) in the largest
///        connected region of cells with min_clearance, ordered into a short tour (nearest
///        neighbour + 2-opt on A* lengths) and joined by plan_path().
/// @throws plumb::Error when the grid has no cell with min_clearance or fewer than two waypoints.
/// @note Deterministic (no randomness).
Route plan_auto_route(const bim::OccupancyGrid& grid, const RouteSettings& settings = {});

/// @brief Length of a polyline [m]; with `closed` the segment back to the first point counts.
double polyline_length(const std::vector<Vector2d>& points, bool closed);

}  // namespace plumb::sim
