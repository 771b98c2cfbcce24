// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Floor-plan slice of a BimMesh: the occupancy grid of one storey, as a robot at floor
///        level sees it (walls, columns, stairs, furniture occupy; doors are open).

#include <cstdint>
#include <string>
#include <vector>

#include "plumb/bim/mesh.hpp"
#include "plumb/core/types.hpp"

namespace plumb::bim {

/// @brief State of one grid cell.
enum class CellState : std::uint8_t {
  kOutside = 0,   ///< no floor under the cell (outside the building or a hole in the slab)
  kFree = 1,      ///< floor below, nothing in the slice above it
  kOccupied = 2,  ///< some element crosses the slice above the cell
};

/// @brief Where a floor plan's free floor came from.
enum class FloorSource : std::uint8_t {
  kSurfaces = 0,  ///< horizontal faces near the storey elevation (slabs, floor coverings, ...)
  kWalls = 1,     ///< the region enclosed by the storey's walls and doors (no floor surface modelled)
  kSpaces = 2,    ///< the footprints of the storey's rooms (IfcSpace), with what floor surfaces there are
};

/// @brief Stable lower-case name: "surfaces", "walls" or "spaces".
inline const char* to_string(FloorSource s) {
  return s == FloorSource::kWalls ? "walls" : s == FloorSource::kSpaces ? "spaces" : "surfaces";
}

/// @brief True when the floor is matter a scanner sees (slabs, coverings), not derived from rooms
///        or walls.
inline bool is_modelled(FloorSource s) { return s == FloorSource::kSurfaces; }

/// @brief A 2D occupancy grid in the mesh frame's x-y plane; cell (ix, iy) covers
///        [origin + (ix, iy) * resolution, origin + (ix + 1, iy + 1) * resolution).
struct OccupancyGrid {
  double resolution = 0.05;            ///< cell size [m]
  Vector2d origin = Vector2d::Zero();  ///< corner of cell (0, 0), mesh frame [m]
  int width = 0;                       ///< cells along x
  int height = 0;                      ///< cells along y
  std::vector<CellState> cells;        ///< row-major: index iy * width + ix
  int storey = -1;                     ///< BimMesh::storeys index, -1 when not from a storey
  double floor_z = 0.0;                ///< floor height of the storey, mesh frame [m]
  FloorSource floor_source = FloorSource::kSurfaces;  ///< where the free cells' floor came from
  bool has_doors = false;              ///< a door crosses the obstacle slice

  bool in_bounds(int ix, int iy) const { return ix >= 0 && iy >= 0 && ix < width && iy < height; }
  std::size_t index(int ix, int iy) const {
    return static_cast<std::size_t>(iy) * static_cast<std::size_t>(width) + static_cast<std::size_t>(ix);
  }
  /// @brief State of a cell; kOutside outside the grid.
  CellState at(int ix, int iy) const { return in_bounds(ix, iy) ? cells[index(ix, iy)] : CellState::kOutside; }
  /// @brief Cell containing the point (may be out of bounds).
  Eigen::Vector2i cell_of(const Vector2d& p) const;
  /// @brief Centre of a cell [m].
  Vector2d center(int ix, int iy) const;
  /// @brief True when the point lies in a free cell.
  bool is_free(const Vector2d& p) const;
  /// @brief Number of free cells times the cell area [m^2].
  double free_area() const;
};

/// @brief Settings of floor_plan().
struct OccupancyGridSettings {
  int storey = -1;            ///< BimMesh::storeys index; -1 = the storey with the largest free floor area
  double resolution = 0.05;   ///< cell size [m]
  double slice_min = 0.3;     ///< bottom of the obstacle slice above the storey elevation [m]
  double slice_max = 1.5;     ///< top of the obstacle slice above the storey elevation [m]
  double floor_below = 0.6;   ///< floor surfaces count from elevation - floor_below ... [m]
  double floor_above = 0.25;  ///< ... to elevation + floor_above [m]
  double margin = 1.0;        ///< grid margin around the model's x-y bounds [m]
  double min_walkable_area = 4.0;  ///< a storey with less free floor is not walkable [m^2]
  /// A storey whose floor surfaces cover less than min_walkable_area or less than
  /// min_surface_fraction of what its walls, windows and doors enclose in the obstacle slice (real
  /// architectural exports often keep the ground slab in the structural model) takes that
  /// enclosure as its floor, gaps narrower than enclosure_gap closed [m]; 0 disables it.
  double enclosure_gap = 0.3;
  double min_surface_fraction = 0.5;
  /// IFC types that do not block the robot: doors are open, spaces and openings are not matter.
  std::vector<std::string> ignored_types = {"IfcDoor", "IfcSpace", "IfcOpeningElement",
                                            "IfcOpeningStandardCase", "IfcAnnotation", "IfcSite"};
  /// Rooms: where the floor surfaces fall short (as for enclosure_gap), the footprints of these
  /// elements' horizontal faces in the floor band count as floor too (FloorSource::kSpaces).
  std::vector<std::string> space_types = {"IfcSpace"};
  /// Not walkable by a wheeled robot: every cell under these elements, from the floor band up to
  /// the top of the obstacle slice, is occupied (a first step or a ramp's foot would read as floor).
  std::vector<std::string> unwalkable_types = {"IfcStair", "IfcStairFlight", "IfcRamp", "IfcRampFlight"};
};

/// @brief Floor-plan slice of one storey: cells with a floor surface near the storey elevation
///        (upward or downward facing horizontal triangles) that no element crosses between
///        slice_min and slice_max above it are free; cells crossed are occupied; the rest outside.
///        Where the floor surfaces are missing (see enclosure_gap), the footprints of the storey's
///        rooms (space_types) are added when they make up the floor (kSpaces), else the cells
///        enclosed by the storey's walls and doors are the floor (kWalls). Stairs and ramps
///        (unwalkable_types) are occupied.
///        With storey = -1, the largest storey with modelled floors is taken, else the largest
///        enclosure with doors, else the largest enclosure.
/// @param mesh building mesh (openings already cut by build_mesh()).
/// @throws plumb::Error when the mesh has no storey, the requested storey does not exist or is not
///         walkable, or (storey = -1) no storey has min_walkable_area of free floor.
/// @note O(triangles + cells) per storey tried.
OccupancyGrid floor_plan(const BimMesh& mesh, const OccupancyGridSettings& settings = {});

/// @brief Free floor area of every storey [m^2] (same slicing as floor_plan()), in storey order.
std::vector<double> storey_free_areas(const BimMesh& mesh, const OccupancyGridSettings& settings = {});

/// @brief One storey's floor as floor_plan() finds it.
struct StoreyFloor {
  double free_area = 0.0;                            ///< [m^2]
  FloorSource source = FloorSource::kSurfaces;       ///< where it came from
};

/// @brief The floor of every storey (same slicing as floor_plan()), in storey order.
std::vector<StoreyFloor> storey_floors(const BimMesh& mesh, const OccupancyGridSettings& settings = {});

}  // namespace plumb::bim
