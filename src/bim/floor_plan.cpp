// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/bim/floor_plan.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "plumb/core/error.hpp"

namespace plumb::bim {

Eigen::Vector2i OccupancyGrid::cell_of(const Vector2d& p) const {
  return {static_cast<int>(std::floor((p.x() - origin.x()) / resolution)),
          static_cast<int>(std::floor((p.y() - origin.y()) / resolution))};
}

Vector2d OccupancyGrid::center(int ix, int iy) const {
  return origin + Vector2d((ix + 0.5) * resolution, (iy + 0.5) * resolution);
}

bool OccupancyGrid::is_free(const Vector2d& p) const {
  const Eigen::Vector2i c = cell_of(p);
  return at(c.x(), c.y()) == CellState::kFree;
}

double OccupancyGrid::free_area() const {
  const auto n = std::count(cells.begin(), cells.end(), CellState::kFree);
  return static_cast<double>(n) * resolution * resolution;
}

namespace {

/// Marks cells whose centre lies inside the triangle a b c, and (when `edges`) every cell an edge
/// passes through (sampled at a quarter cell), with `mark(index)`.
template <class Mark>
void rasterize_triangle(const OccupancyGrid& g, const Vector2d& a, const Vector2d& b, const Vector2d& c,
                        bool edges, Mark&& mark) {
  const double area2 = (b - a).x() * (c - a).y() - (b - a).y() * (c - a).x();
  if (std::abs(area2) > 1e-12) {
    const Vector2d lo = a.cwiseMin(b).cwiseMin(c), hi = a.cwiseMax(b).cwiseMax(c);
    const Eigen::Vector2i c0 = g.cell_of(lo), c1 = g.cell_of(hi);
    const int x0 = std::max(c0.x(), 0), y0 = std::max(c0.y(), 0);
    const int x1 = std::min(c1.x(), g.width - 1), y1 = std::min(c1.y(), g.height - 1);
    for (int iy = y0; iy <= y1; ++iy) {
      for (int ix = x0; ix <= x1; ++ix) {
        const Vector2d p = g.center(ix, iy);
        const double w0 = ((b - p).x() * (c - p).y() - (b - p).y() * (c - p).x()) / area2;
        const double w1 = ((c - p).x() * (a - p).y() - (c - p).y() * (a - p).x()) / area2;
        const double w2 = 1.0 - w0 - w1;
        if (w0 >= 0.0 && w1 >= 0.0 && w2 >= 0.0) mark(g.index(ix, iy));
      }
    }
  }
  if (!edges) return;
  const Vector2d* v[3] = {&a, &b, &c};
  for (int e = 0; e < 3; ++e) {
    const Vector2d& p = *v[e];
    const Vector2d& q = *v[(e + 1) % 3];
    const double len = (q - p).norm();
    const int steps = std::max(1, static_cast<int>(std::ceil(len / (0.25 * g.resolution))));
    for (int s = 0; s <= steps; ++s) {
      const Eigen::Vector2i cell = g.cell_of(p + (q - p) * (static_cast<double>(s) / steps));
      if (g.in_bounds(cell.x(), cell.y())) mark(g.index(cell.x(), cell.y()));
    }
  }
}

/// Sutherland-Hodgman clip of a polygon to z >= lo (sign = +1) or z <= hi (sign = -1).
std::vector<Vector3d> clip_z(const std::vector<Vector3d>& poly, double z, double sign) {
  std::vector<Vector3d> out;
  const std::size_t n = poly.size();
  for (std::size_t i = 0; i < n; ++i) {
    const Vector3d& p = poly[i];
    const Vector3d& q = poly[(i + 1) % n];
    const double dp = sign * (p.z() - z), dq = sign * (q.z() - z);
    if (dp >= 0.0) out.push_back(p);
    if ((dp >= 0.0) != (dq >= 0.0)) out.push_back(p + (q - p) * (dp / (dp - dq)));
  }
  return out;
}

/// The IFC type of a mesh element; empty for a triangle that belongs to none.
const std::string& type_of(const BimMesh& mesh, std::int32_t element) {
  static const std::string none;
  if (element < 0 || static_cast<std::size_t>(element) >= mesh.elements.size()) return none;
  return mesh.elements[static_cast<std::size_t>(element)].type;
}

/// Marks the cells whose centre lies inside the closed surface of one element at height z
/// (even-odd rule on the element's cross-section, row by row). Rows with an odd number of
/// crossings (an open surface) are left alone.
template <class Mark>
void fill_cross_section(const OccupancyGrid& g, const BimMesh& mesh, const BimElement& e, double z,
                        std::vector<std::pair<Vector2d, Vector2d>>& segments, std::vector<double>& xs, Mark&& mark) {
  segments.clear();
  const std::size_t end = std::min(e.first_triangle + e.num_triangles, mesh.triangles.size());
  for (std::size_t t = e.first_triangle; t < end; ++t) {
    const auto& tri = mesh.triangles[t];
    Vector2d pts[2];
    int n = 0;
    for (int k = 0; k < 3 && n < 2; ++k) {
      const Vector3d& a = mesh.vertices[tri[static_cast<std::size_t>(k)]];
      const Vector3d& b = mesh.vertices[tri[static_cast<std::size_t>((k + 1) % 3)]];
      if ((a.z() >= z) == (b.z() >= z)) continue;
      const double f = (z - a.z()) / (b.z() - a.z());
      pts[n++] = (a + f * (b - a)).head<2>();
    }
    if (n == 2) segments.emplace_back(pts[0], pts[1]);
  }
  if (segments.size() < 2) return;
  double y_lo = std::numeric_limits<double>::infinity(), y_hi = -y_lo;
  for (const auto& [p, q] : segments) {
    y_lo = std::min({y_lo, p.y(), q.y()});
    y_hi = std::max({y_hi, p.y(), q.y()});
  }
  const int iy0 = std::max(0, g.cell_of({0.0, y_lo}).y()), iy1 = std::min(g.height - 1, g.cell_of({0.0, y_hi}).y());
  for (int iy = iy0; iy <= iy1; ++iy) {
    const double y = g.center(0, iy).y();
    xs.clear();
    for (const auto& [p, q] : segments) {
      if ((p.y() > y) == (q.y() > y)) continue;
      xs.push_back(p.x() + (y - p.y()) / (q.y() - p.y()) * (q.x() - p.x()));
    }
    if (xs.size() % 2 != 0) continue;
    std::sort(xs.begin(), xs.end());
    for (std::size_t k = 0; k + 1 < xs.size(); k += 2) {
      const int ix0 = std::max(0, static_cast<int>(std::ceil((xs[k] - g.origin.x()) / g.resolution - 0.5)));
      const int ix1 = std::min(g.width - 1, static_cast<int>(std::floor((xs[k + 1] - g.origin.x()) / g.resolution - 0.5)));
      for (int ix = ix0; ix <= ix1; ++ix) mark(g.index(ix, iy));
    }
  }
}

/// True when the element's IFC type is one of `types`.
bool has_type(const BimMesh& mesh, std::int32_t element, const std::vector<std::string>& types) {
  const std::string& type = type_of(mesh, element);
  return !type.empty() && std::find(types.begin(), types.end(), type) != types.end();
}

bool is_door(const BimMesh& mesh, std::int32_t element) {
  const std::string& type = type_of(mesh, element);
  return type == "IfcDoor" || type == "IfcDoorStandardCase";
}

/// Cells enclosed by the barriers (obstacles and doors): not reachable from the grid's border
/// through barrier-free cells. Gaps narrower than `gap` between barriers are closed first (the
/// barriers grown by gap / 2), and the outside then grows back by as much through cells free of
/// obstacles, so the closing neither leaks in nor leaves a strip outside the exterior walls.
std::vector<std::uint8_t> enclosed_cells(const OccupancyGrid& g, const std::vector<std::uint8_t>& occupied,
                                         const std::vector<std::uint8_t>& door, double gap) {
  const std::size_t n = occupied.size();
  const int r = std::max(1, static_cast<int>(std::ceil(0.5 * gap / g.resolution)));
  // Barriers grown by r cells (Chebyshev), separably: rows, then columns.
  std::vector<std::uint8_t> rows(n, 0), grown(n, 0);
  for (int iy = 0; iy < g.height; ++iy) {
    int last = -1'000'000;  // x of the last barrier seen, left to right, then right to left
    for (int ix = 0; ix < g.width; ++ix) {
      const std::size_t i = g.index(ix, iy);
      if (occupied[i] || door[i]) last = ix;
      if (ix - last <= r) rows[i] = 1;
    }
    last = 1'000'000;
    for (int ix = g.width - 1; ix >= 0; --ix) {
      const std::size_t i = g.index(ix, iy);
      if (occupied[i] || door[i]) last = ix;
      if (last - ix <= r) rows[i] = 1;
    }
  }
  for (int ix = 0; ix < g.width; ++ix) {
    int last = -1'000'000;
    for (int iy = 0; iy < g.height; ++iy) {
      if (rows[g.index(ix, iy)]) last = iy;
      if (iy - last <= r) grown[g.index(ix, iy)] = 1;
    }
    last = 1'000'000;
    for (int iy = g.height - 1; iy >= 0; --iy) {
      if (rows[g.index(ix, iy)]) last = iy;
      if (last - iy <= r) grown[g.index(ix, iy)] = 1;
    }
  }
  // Outside: flood from the border through cells off the grown barriers (4-connected), then r more
  // steps through cells that are not obstacles.
  std::vector<int> depth(n, -1);
  std::vector<std::size_t> frontier, next;
  for (int iy = 0; iy < g.height; ++iy) {
    for (int ix = 0; ix < g.width; ++ix) {
      if (ix != 0 && iy != 0 && ix != g.width - 1 && iy != g.height - 1) continue;
      const std::size_t i = g.index(ix, iy);
      if (!grown[i] && depth[i] < 0) {
        depth[i] = 0;
        frontier.push_back(i);
      }
    }
  }
  const int dx[4] = {1, -1, 0, 0}, dy[4] = {0, 0, 1, -1};
  auto expand = [&](bool through_grown) {
    next.clear();
    for (std::size_t i : frontier) {
      const int ix = static_cast<int>(i % static_cast<std::size_t>(g.width));
      const int iy = static_cast<int>(i / static_cast<std::size_t>(g.width));
      for (int k = 0; k < 4; ++k) {
        if (!g.in_bounds(ix + dx[k], iy + dy[k])) continue;
        const std::size_t j = g.index(ix + dx[k], iy + dy[k]);
        if (depth[j] >= 0 || occupied[j] || (!through_grown && grown[j])) continue;
        depth[j] = 0;
        next.push_back(j);
      }
    }
    frontier.swap(next);
  };
  std::vector<std::size_t> reached = frontier;
  while (!frontier.empty()) {
    expand(false);
    reached.insert(reached.end(), frontier.begin(), frontier.end());
  }
  frontier = reached;
  for (int step = 0; step < r && !frontier.empty(); ++step) expand(true);
  std::vector<std::uint8_t> inside(n, 0);
  for (std::size_t i = 0; i < n; ++i) inside[i] = depth[i] < 0 ? 1 : 0;
  return inside;
}

OccupancyGrid slice_storey(const BimMesh& mesh, int storey, const OccupancyGridSettings& s) {
  Vector3d lo, hi;
  mesh.bounds(lo, hi);
  OccupancyGrid g;
  g.resolution = s.resolution;
  g.storey = storey;
  g.floor_z = mesh.storeys[static_cast<std::size_t>(storey)].elevation;
  g.origin = lo.head<2>() - Vector2d::Constant(s.margin);
  const Vector2d extent = hi.head<2>() - lo.head<2>() + Vector2d::Constant(2.0 * s.margin);
  const double cells_x = std::ceil(extent.x() / s.resolution), cells_y = std::ceil(extent.y() / s.resolution);
  PLUMB_CHECK(cells_x * cells_y < 2.0e8, "floor_plan: grid of " << cells_x << " x " << cells_y
                                                                << " cells is too large; raise the resolution");
  g.width = std::max(1, static_cast<int>(cells_x));
  g.height = std::max(1, static_cast<int>(cells_y));
  std::vector<std::uint8_t> floor(static_cast<std::size_t>(g.width) * static_cast<std::size_t>(g.height), 0);
  std::vector<std::uint8_t> occupied(floor.size(), 0);

  const double floor_lo = g.floor_z - s.floor_below, floor_hi = g.floor_z + s.floor_above;
  const double slice_lo = g.floor_z + s.slice_min, slice_hi = g.floor_z + s.slice_max;
  // Doors are open for the robot but close a room: the walls' enclosure (below) needs them.
  std::vector<std::uint8_t> door(floor.size(), 0);
  std::vector<std::uint8_t> space(floor.size(), 0);  // room footprints (space_types)
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    const std::int32_t element = t < mesh.triangle_element.size() ? mesh.triangle_element[t] : -1;
    const auto& tri = mesh.triangles[t];
    const Vector3d& a = mesh.vertices[tri[0]];
    const Vector3d& b = mesh.vertices[tri[1]];
    const Vector3d& c = mesh.vertices[tri[2]];
    const double zmin = std::min({a.z(), b.z(), c.z()}), zmax = std::max({a.z(), b.z(), c.z()});
    const Vector3d n = (b - a).cross(c - a);
    const double nn = n.norm();
    const bool horizontal_in_floor_band = nn > 0.0 && std::abs(n.z()) > 0.95 * nn && zmin >= floor_lo && zmax <= floor_hi;
    if (has_type(mesh, element, s.space_types)) {
      if (horizontal_in_floor_band) {
        rasterize_triangle(g, a.head<2>(), b.head<2>(), c.head<2>(), false, [&](std::size_t i) { space[i] = 1; });
      }
    }
    if (has_type(mesh, element, s.ignored_types)) {
      if (is_door(mesh, element) && zmax >= slice_lo && zmin <= slice_hi) {
        rasterize_triangle(g, a.head<2>(), b.head<2>(), c.head<2>(), true, [&](std::size_t i) { door[i] = 1; });
      }
      continue;
    }
    if (has_type(mesh, element, s.unwalkable_types)) {
      if (zmax >= floor_lo && zmin <= slice_hi) {
        rasterize_triangle(g, a.head<2>(), b.head<2>(), c.head<2>(), true, [&](std::size_t i) { occupied[i] = 1; });
      }
      continue;
    }
    // Floor: a (near) horizontal triangle within the floor band.
    if (horizontal_in_floor_band) {
      rasterize_triangle(g, a.head<2>(), b.head<2>(), c.head<2>(), false,
                         [&](std::size_t i) { floor[i] = 1; });
    }
    // Obstacles: the part of the triangle inside the slice.
    if (zmax < slice_lo || zmin > slice_hi) continue;
    std::vector<Vector3d> poly = clip_z(clip_z({a, b, c}, slice_lo, 1.0), slice_hi, -1.0);
    if (poly.empty()) continue;
    if (poly.size() < 3) poly.resize(3, poly.back());
    for (std::size_t k = 1; k + 1 < poly.size(); ++k) {
      rasterize_triangle(g, poly[0].head<2>(), poly[k].head<2>(), poly[k + 1].head<2>(), true,
                         [&](std::size_t i) { occupied[i] = 1; });
    }
  }
  // Inside of closed elements (thick walls, columns) crossing the slice: their faces in the slice
  // only outline them.
  std::vector<std::pair<Vector2d, Vector2d>> segments;
  std::vector<double> xs;
  for (std::size_t e = 0; e < mesh.elements.size(); ++e) {
    const BimElement& el = mesh.elements[e];
    if (el.num_triangles == 0 || has_type(mesh, static_cast<std::int32_t>(e), s.ignored_types)) continue;
    for (double z : {slice_lo + 0.01, 0.5 * (slice_lo + slice_hi), slice_hi - 0.01}) {
      fill_cross_section(g, mesh, el, z, segments, xs, [&](std::size_t i) { occupied[i] = 1; });
    }
  }
  g.cells.resize(floor.size());
  for (std::size_t i = 0; i < floor.size(); ++i) {
    g.cells[i] = occupied[i] ? CellState::kOccupied : (floor[i] ? CellState::kFree : CellState::kOutside);
  }
  g.floor_source = FloorSource::kSurfaces;
  g.has_doors = std::find(door.begin(), door.end(), 1) != door.end();
  if (s.enclosure_gap <= 0.0) return g;
  // Floor surfaces missing under much of what the walls enclose (a ground slab kept in the
  // structural model, floors not modelled): the rooms' footprints when they make up the floor,
  // else what the walls, windows and doors enclose.
  const std::vector<std::uint8_t> inside = enclosed_cells(g, occupied, door, s.enclosure_gap);
  OccupancyGrid walls = g;
  walls.floor_source = FloorSource::kWalls;
  for (std::size_t i = 0; i < floor.size(); ++i) {
    walls.cells[i] = occupied[i] ? CellState::kOccupied : (inside[i] ? CellState::kFree : CellState::kOutside);
  }
  const double walls_area = walls.free_area();
  auto enough = [&](double area) { return area >= s.min_walkable_area && area >= s.min_surface_fraction * walls_area; };
  const double surface_area = g.free_area();
  if (enough(surface_area)) return g;
  OccupancyGrid rooms = g;
  rooms.floor_source = FloorSource::kSpaces;
  for (std::size_t i = 0; i < floor.size(); ++i) {
    if (space[i] && !occupied[i]) rooms.cells[i] = CellState::kFree;
  }
  const double rooms_area = rooms.free_area();
  if (rooms_area > surface_area && enough(rooms_area)) return rooms;
  return walls_area > surface_area ? walls : g;
}

void check_settings(const BimMesh& mesh, const OccupancyGridSettings& s) {
  PLUMB_CHECK(s.resolution > 0.0 && std::isfinite(s.resolution),
              "floor_plan: resolution must be positive, got " << s.resolution);
  PLUMB_CHECK(s.slice_max > s.slice_min, "floor_plan: slice_max (" << s.slice_max << ") must exceed slice_min ("
                                                                   << s.slice_min << ")");
  PLUMB_CHECK(s.margin >= 0.0, "floor_plan: margin must not be negative");
  PLUMB_CHECK(!mesh.triangles.empty(), "floor_plan: the mesh has no triangles");
  PLUMB_CHECK(!mesh.storeys.empty(), "floor_plan: the model has no storey (IfcBuildingStorey); nothing is walkable");
}

}  // namespace

std::vector<double> storey_free_areas(const BimMesh& mesh, const OccupancyGridSettings& settings) {
  std::vector<double> areas;
  for (const StoreyFloor& f : storey_floors(mesh, settings)) areas.push_back(f.free_area);
  return areas;
}

std::vector<StoreyFloor> storey_floors(const BimMesh& mesh, const OccupancyGridSettings& settings) {
  check_settings(mesh, settings);
  std::vector<StoreyFloor> floors;
  for (std::size_t k = 0; k < mesh.storeys.size(); ++k) {
    const OccupancyGrid g = slice_storey(mesh, static_cast<int>(k), settings);
    floors.push_back({g.free_area(), g.floor_source});
  }
  return floors;
}

OccupancyGrid floor_plan(const BimMesh& mesh, const OccupancyGridSettings& settings) {
  check_settings(mesh, settings);
  const int num_storeys = static_cast<int>(mesh.storeys.size());
  if (settings.storey >= 0) {
    PLUMB_CHECK(settings.storey < num_storeys, "floor_plan: storey " << settings.storey << " does not exist (the model has "
                                                                     << num_storeys << " storeys)");
    OccupancyGrid g = slice_storey(mesh, settings.storey, settings);
    const auto& st = mesh.storeys[static_cast<std::size_t>(settings.storey)];
    PLUMB_CHECK(g.free_area() >= settings.min_walkable_area,
                "floor_plan: storey " << settings.storey << " '" << st.name << "' (elevation " << st.elevation
                                      << " m) is not walkable: " << g.free_area() << " m^2 of free floor < "
                                      << settings.min_walkable_area
                                      << " m^2 (neither floor surfaces near its elevation nor rooms closed by walls"
                                         " and doors in the slice " << settings.slice_min << "-" << settings.slice_max
                                      << " m above it)");
    return g;
  }
  // The largest walkable storey, preferring floors that are modelled, then rooms, then enclosures with doors
  // (a foundation's walls enclose as much as the floor above, but no robot drives there).
  OccupancyGrid best;
  double best_area = -1.0;
  int best_rank = -1;
  for (int k = 0; k < num_storeys; ++k) {
    OccupancyGrid g = slice_storey(mesh, k, settings);
    const double area = g.free_area();
    const int rank = area < settings.min_walkable_area ? 0
                     : g.floor_source == FloorSource::kSurfaces ? 4
                     : g.floor_source == FloorSource::kSpaces ? 3
                     : g.has_doors ? 2
                                   : 1;
    if (rank > best_rank || (rank == best_rank && area > best_area)) {
      best_rank = rank;
      best_area = area;
      best = std::move(g);
    }
  }
  PLUMB_CHECK(best_area >= settings.min_walkable_area,
              "floor_plan: no walkable storey in the model: the largest free floor area of its "
                  << num_storeys << " storeys is " << best_area << " m^2 < " << settings.min_walkable_area
                  << " m^2 (no floor surface near a storey elevation and no room enclosed by walls, or every"
                     " floor is blocked)");
  return best;
}

}  // namespace plumb::bim
