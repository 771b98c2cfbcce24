// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/sim/route.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <queue>
#include <utility>

#include "plumb/core/error.hpp"

namespace plumb::sim {
namespace {

using bim::CellState;
using bim::OccupancyGrid;

constexpr double kInf = std::numeric_limits<double>::infinity();

constexpr double kFar = 1e20;  // "no obstacle" sample value of the distance transform

/// 1D squared distance transform of sampled function f (Felzenszwalb & Huttenlocher 2012, alg. 1).
void distance_transform_1d(const std::vector<double>& f, std::vector<double>& d, std::vector<int>& v,
                           std::vector<double>& z) {
  const int n = static_cast<int>(f.size());
  auto at = [&](int i) { return f[static_cast<std::size_t>(i)]; };
  int k = 0;
  v[0] = 0;
  z[0] = -kInf;
  z[1] = kInf;
  for (int q = 1; q < n; ++q) {
    double s = 0.0;
    for (;;) {
      const int p = v[static_cast<std::size_t>(k)];
      s = ((at(q) + double(q) * q) - (at(p) + double(p) * p)) / (2.0 * (q - p));
      if (s > z[static_cast<std::size_t>(k)]) break;
      --k;
    }
    ++k;
    v[static_cast<std::size_t>(k)] = q;
    z[static_cast<std::size_t>(k)] = s;
    z[static_cast<std::size_t>(k) + 1] = kInf;
  }
  k = 0;
  for (int q = 0; q < n; ++q) {
    while (z[static_cast<std::size_t>(k) + 1] < q) ++k;
    const int p = v[static_cast<std::size_t>(k)];
    d[static_cast<std::size_t>(q)] = double(q - p) * (q - p) + at(p);
  }
}

double octile(int dx, int dy) {
  dx = std::abs(dx);
  dy = std::abs(dy);
  return std::max(dx, dy) + (std::sqrt(2.0) - 1.0) * std::min(dx, dy);
}

float clearance_at(const OccupancyGrid& g, const std::vector<float>& clr, const Vector2d& p) {
  const Eigen::Vector2i c = g.cell_of(p);
  return g.in_bounds(c.x(), c.y()) ? clr[g.index(c.x(), c.y())] : 0.0f;
}

/// True when every sample of segment p-q (every half cell) has clearance >= required.
bool segment_clear(const OccupancyGrid& g, const std::vector<float>& clr, const Vector2d& p, const Vector2d& q,
                   double required) {
  const double len = (q - p).norm();
  const int steps = std::max(1, static_cast<int>(std::ceil(len / (0.5 * g.resolution))));
  for (int s = 0; s <= steps; ++s) {
    if (clearance_at(g, clr, p + (q - p) * (double(s) / steps)) < required) return false;
  }
  return true;
}

/// A* over cells; returns cell indices from start to goal, empty if unreachable.
std::vector<std::size_t> astar_cells(const OccupancyGrid& g, const std::vector<float>& clr, Eigen::Vector2i start,
                                     Eigen::Vector2i goal, const RouteSettings& s) {
  const std::size_t n = g.cells.size();
  std::vector<double> cost(n, kInf);
  std::vector<std::int64_t> parent(n, -1);
  std::vector<std::uint8_t> closed(n, 0);
  using Entry = std::pair<double, std::size_t>;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> open;
  const std::size_t i0 = g.index(start.x(), start.y()), i1 = g.index(goal.x(), goal.y());
  cost[i0] = 0.0;
  open.push({octile(goal.x() - start.x(), goal.y() - start.y()), i0});
  static const int kDx[8] = {1, -1, 0, 0, 1, 1, -1, -1};
  static const int kDy[8] = {0, 0, 1, -1, 1, -1, 1, -1};
  const double min_clr = s.min_clearance, pref = std::max(s.preferred_clearance, 1e-9);
  while (!open.empty()) {
    const std::size_t i = open.top().second;
    open.pop();
    if (closed[i]) continue;
    closed[i] = 1;
    if (i == i1) break;
    const int ix = static_cast<int>(i % static_cast<std::size_t>(g.width));
    const int iy = static_cast<int>(i / static_cast<std::size_t>(g.width));
    for (int k = 0; k < 8; ++k) {
      const int jx = ix + kDx[k], jy = iy + kDy[k];
      if (!g.in_bounds(jx, jy)) continue;
      const std::size_t j = g.index(jx, jy);
      if (closed[j] || clr[j] < min_clr) continue;
      const double step = k < 4 ? 1.0 : std::sqrt(2.0);
      const double margin = std::max(0.0, pref - static_cast<double>(clr[j])) / pref;
      const double c = cost[i] + step * (1.0 + s.clearance_weight * margin);
      if (c < cost[j]) {
        cost[j] = c;
        parent[j] = static_cast<std::int64_t>(i);
        open.push({c + octile(goal.x() - jx, goal.y() - jy), j});
      }
    }
  }
  if (!closed[i1]) return {};
  std::vector<std::size_t> cells;
  for (std::int64_t i = static_cast<std::int64_t>(i1); i >= 0; i = parent[static_cast<std::size_t>(i)]) {
    cells.push_back(static_cast<std::size_t>(i));
  }
  std::reverse(cells.begin(), cells.end());
  return cells;
}

Eigen::Vector2i checked_cell(const OccupancyGrid& g, const std::vector<float>& clr, const Vector2d& p,
                             const RouteSettings& s, const char* what) {
  const Eigen::Vector2i c = g.cell_of(p);
  PLUMB_CHECK(g.in_bounds(c.x(), c.y()), "plan_path: " << what << " (" << p.x() << ", " << p.y()
                                                       << ") is outside the grid");
  PLUMB_CHECK(clr[g.index(c.x(), c.y())] >= s.min_clearance,
              "plan_path: " << what << " (" << p.x() << ", " << p.y() << ") has clearance "
                            << clr[g.index(c.x(), c.y())] << " m < min_clearance " << s.min_clearance << " m");
  return c;
}

}  // namespace

std::vector<float> clearance_map(const OccupancyGrid& g) {
  PLUMB_CHECK(g.width > 0 && g.height > 0 &&
                  g.cells.size() == static_cast<std::size_t>(g.width) * static_cast<std::size_t>(g.height),
              "clearance_map: grid of " << g.width << " x " << g.height << " has " << g.cells.size() << " cells");
  const int w = g.width, h = g.height;
  const int m = std::max(w, h);
  std::vector<double> grid(g.cells.size());
  for (std::size_t i = 0; i < grid.size(); ++i) grid[i] = g.cells[i] == CellState::kFree ? kFar : 0.0;
  std::vector<double> f(static_cast<std::size_t>(m)), d(static_cast<std::size_t>(m)), z(static_cast<std::size_t>(m) + 1);
  std::vector<int> v(static_cast<std::size_t>(m));
  // Columns, then rows.
  for (int x = 0; x < w; ++x) {
    f.resize(static_cast<std::size_t>(h));
    d.resize(static_cast<std::size_t>(h));
    for (int y = 0; y < h; ++y) f[static_cast<std::size_t>(y)] = grid[g.index(x, y)];
    distance_transform_1d(f, d, v, z);
    for (int y = 0; y < h; ++y) grid[g.index(x, y)] = d[static_cast<std::size_t>(y)];
  }
  for (int y = 0; y < h; ++y) {
    f.resize(static_cast<std::size_t>(w));
    d.resize(static_cast<std::size_t>(w));
    for (int x = 0; x < w; ++x) f[static_cast<std::size_t>(x)] = grid[g.index(x, y)];
    distance_transform_1d(f, d, v, z);
    for (int x = 0; x < w; ++x) grid[g.index(x, y)] = d[static_cast<std::size_t>(x)];
  }
  std::vector<float> out(grid.size());
  const double big = 1e6;  // a grid without any obstacle: everything is far
  for (std::size_t i = 0; i < grid.size(); ++i) {
    out[i] = static_cast<float>(grid[i] >= 0.5 * kFar ? big : std::sqrt(grid[i]) * g.resolution);
  }
  return out;
}

double polyline_length(const std::vector<Vector2d>& points, bool closed) {
  double len = 0.0;
  for (std::size_t i = 1; i < points.size(); ++i) len += (points[i] - points[i - 1]).norm();
  if (closed && points.size() > 1) len += (points.front() - points.back()).norm();
  return len;
}

std::vector<Vector2d> plan_path(const OccupancyGrid& g, const std::vector<float>& clr, const Vector2d& start,
                                const Vector2d& goal, const RouteSettings& s) {
  PLUMB_CHECK(clr.size() == g.cells.size(), "plan_path: clearance map has " << clr.size() << " cells, the grid "
                                                                            << g.cells.size());
  PLUMB_CHECK(s.min_clearance >= 0.0 && s.clearance_weight >= 0.0, "plan_path: negative clearance setting");
  const Eigen::Vector2i c0 = checked_cell(g, clr, start, s, "start");
  const Eigen::Vector2i c1 = checked_cell(g, clr, goal, s, "goal");
  const std::vector<std::size_t> cells = astar_cells(g, clr, c0, c1, s);
  if (cells.empty()) return {};
  std::vector<Vector2d> raw;
  std::vector<float> raw_clr;
  raw.reserve(cells.size());
  for (std::size_t i : cells) {
    const int ix = static_cast<int>(i % static_cast<std::size_t>(g.width));
    const int iy = static_cast<int>(i / static_cast<std::size_t>(g.width));
    raw.push_back(g.center(ix, iy));
    raw_clr.push_back(clr[i]);
  }
  raw.front() = start;
  raw.back() = goal;
  if (raw.size() == 1) return {start, goal};
  // Line-of-sight shortcuts that never come closer to obstacles than the cells they replace
  // (up to preferred_clearance).
  std::vector<Vector2d> path{raw.front()};
  std::size_t i = 0;
  while (i + 1 < raw.size()) {
    std::size_t best = i + 1;
    double min_clr = std::min(raw_clr[i], raw_clr[i + 1]);
    for (std::size_t j = i + 2; j < raw.size(); ++j) {
      min_clr = std::min(min_clr, static_cast<double>(raw_clr[j]));
      const double required = std::max(s.min_clearance, std::min(s.preferred_clearance, min_clr)) - 1e-6;
      if (!segment_clear(g, clr, raw[i], raw[j], required)) break;
      best = j;
    }
    path.push_back(raw[best]);
    i = best;
  }
  return path;
}

namespace {

/// The cells of the largest 8-connected region the robot may occupy (clearance >= min_clearance):
/// region label per cell (-1 = none) and the label of the largest.
struct DrivableRegion {
  std::vector<int> region;
  int best = -1;
};

DrivableRegion largest_drivable_region(const OccupancyGrid& g, const std::vector<float>& clr, double min_clearance) {
  const std::size_t n = g.cells.size();
  DrivableRegion out;
  std::vector<int>& region = out.region;
  region.assign(n, -1);
  std::size_t best_size = 0;
  int num_regions = 0;
  std::vector<std::size_t> stack;
  for (std::size_t seed = 0; seed < n; ++seed) {
    if (region[seed] >= 0 || clr[seed] < min_clearance) continue;
    std::size_t size = 0;
    region[seed] = num_regions;
    stack.assign(1, seed);
    while (!stack.empty()) {
      const std::size_t i = stack.back();
      stack.pop_back();
      ++size;
      const int ix = static_cast<int>(i % static_cast<std::size_t>(g.width));
      const int iy = static_cast<int>(i / static_cast<std::size_t>(g.width));
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
          if (!g.in_bounds(ix + dx, iy + dy)) continue;
          const std::size_t j = g.index(ix + dx, iy + dy);
          if (region[j] >= 0 || clr[j] < min_clearance) continue;
          region[j] = num_regions;
          stack.push_back(j);
        }
      }
    }
    if (size > best_size) {
      best_size = size;
      out.best = num_regions;
    }
    ++num_regions;
  }
  return out;
}

/// Places of the region the route visits.
std::vector<Vector2d> route_waypoints(const OccupancyGrid& g, const std::vector<float>& clr,
                                      const DrivableRegion& drivable, const RouteSettings& s) {
  const std::size_t n = g.cells.size();
  const std::vector<int>& region = drivable.region;
  // Waypoints: clearance maxima, each suppressing its surroundings.
  std::vector<std::size_t> order;
  for (std::size_t i = 0; i < n; ++i) {
    if (region[i] == drivable.best && clr[i] >= s.min_waypoint_clearance) order.push_back(i);
  }
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return clr[a] > clr[b]; });
  auto center_of = [&](std::size_t i) {
    return g.center(static_cast<int>(i % static_cast<std::size_t>(g.width)),
                    static_cast<int>(i / static_cast<std::size_t>(g.width)));
  };
  std::vector<Vector2d> waypoints;
  std::vector<double> radius;
  for (std::size_t i : order) {
    if (static_cast<int>(waypoints.size()) >= s.max_waypoints) break;
    const Vector2d p = center_of(i);
    bool near = false;
    for (std::size_t k = 0; k < waypoints.size() && !near; ++k) near = (p - waypoints[k]).norm() < radius[k];
    if (near) continue;
    waypoints.push_back(p);
    radius.push_back(std::max(s.min_waypoint_separation, 1.5 * static_cast<double>(clr[i])));
  }
  // Too few places (a single room): add the reachable cells farthest from the chosen ones.
  while (waypoints.size() < 3) {
    double best = 0.0;
    std::size_t best_i = n;
    for (std::size_t i = 0; i < n; ++i) {
      if (region[i] != drivable.best) continue;
      double d = kInf;
      for (const Vector2d& w : waypoints) d = std::min(d, (center_of(i) - w).norm());
      if (waypoints.empty()) d = clr[i];
      if (d > best) {
        best = d;
        best_i = i;
      }
    }
    if (best_i == n || (!waypoints.empty() && best < 2.0 * g.resolution)) break;
    waypoints.push_back(center_of(best_i));
  }
  return waypoints;
}

/// A short closed tour through all places given their pairwise distances, starting at place 0:
/// nearest neighbour, then 2-opt.
std::vector<std::size_t> short_tour(const std::vector<std::vector<double>>& dist) {
  const std::size_t k = dist.size();
  std::vector<std::size_t> tour{0};
  std::vector<bool> used(k, false);
  used[0] = true;
  while (tour.size() < k) {
    std::size_t next = k;
    for (std::size_t c = 0; c < k; ++c) {
      if (!used[c] && (next == k || dist[tour.back()][c] < dist[tour.back()][next])) next = c;
    }
    used[next] = true;
    tour.push_back(next);
  }
  auto tour_length = [&](const std::vector<std::size_t>& t) {
    double len = 0.0;
    for (std::size_t i = 0; i < t.size(); ++i) len += dist[t[i]][t[(i + 1) % t.size()]];
    return len;
  };
  for (bool improved = true; improved;) {  // 2-opt, the start fixed
    improved = false;
    for (std::size_t i = 1; i + 1 < k; ++i) {
      for (std::size_t j = i + 1; j < k; ++j) {
        std::vector<std::size_t> t = tour;
        std::reverse(t.begin() + static_cast<std::ptrdiff_t>(i), t.begin() + static_cast<std::ptrdiff_t>(j) + 1);
        if (tour_length(t) < tour_length(tour) - 1e-9) {
          tour = t;
          improved = true;
        }
      }
    }
  }
  return tour;
}

}  // namespace

Route plan_auto_route(const OccupancyGrid& g, const RouteSettings& s) {
  PLUMB_CHECK(s.max_waypoints >= 2, "plan_auto_route: max_waypoints must be at least 2, got " << s.max_waypoints);
  const std::vector<float> clr = clearance_map(g);
  const DrivableRegion drivable = largest_drivable_region(g, clr, s.min_clearance);
  PLUMB_CHECK(drivable.best >= 0, "plan_auto_route: no free cell with clearance "
                                      << s.min_clearance << " m (the free space is too narrow)");
  const std::vector<Vector2d> waypoints = route_waypoints(g, clr, drivable, s);
  PLUMB_CHECK(waypoints.size() >= 2, "plan_auto_route: the free space holds fewer than two separate places");
  // Paths between all pairs, then a short tour.
  const std::size_t k = waypoints.size();
  std::vector<std::vector<std::vector<Vector2d>>> paths(k, std::vector<std::vector<Vector2d>>(k));
  std::vector<std::vector<double>> dist(k, std::vector<double>(k, 0.0));
  for (std::size_t a = 0; a < k; ++a) {
    for (std::size_t b = a + 1; b < k; ++b) {
      paths[a][b] = plan_path(g, clr, waypoints[a], waypoints[b], s);
      PLUMB_CHECK(!paths[a][b].empty(), "plan_auto_route: waypoints in one region are not connected (internal)");
      paths[b][a] = std::vector<Vector2d>(paths[a][b].rbegin(), paths[a][b].rend());
      dist[a][b] = dist[b][a] = polyline_length(paths[a][b], false);
    }
  }
  const std::vector<std::size_t> tour = short_tour(dist);
  Route route;
  for (std::size_t i = 0; i < k; ++i) {
    route.waypoints.push_back(waypoints[tour[i]]);
    const std::vector<Vector2d>& leg = paths[tour[i]][tour[(i + 1) % k]];
    for (std::size_t p = 0; p + 1 < leg.size(); ++p) {  // the leg's end is the next leg's start
      if (route.points.empty() || (route.points.back() - leg[p]).norm() > 1e-9) route.points.push_back(leg[p]);
    }
  }
  route.length = polyline_length(route.points, true);
  PLUMB_CHECK(route.length >= s.min_length,
              "plan_auto_route: the largest drivable region (cells with clearance " << s.min_clearance
                  << " m) gives a route of only " << route.length << " m < " << s.min_length
                  << " m: the free floor is too small or too narrow for the robot");
  return route;
}

}  // namespace plumb::sim
