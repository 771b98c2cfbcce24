// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief A procedural office floor written as IFC4: the building `plumb demo` simulates a robot in.
///
/// Layout (plan view, x along the length, y across; the origin is the outer south-west corner):
/// a corridor runs along x through the middle of the floor; rooms line both sides of it (the
/// south row gets the odd room when the count is odd), separated by partition walls, each with one
/// door into the corridor. Exterior walls carry one window per room and one at the east end of
/// the corridor; the west end of the corridor is the entrance door. Every storey has a floor slab,
/// the top storey a roof slab; columns stand at the junctions of partitions and exterior walls.
///
/// Everything is an axis-aligned box: IfcExtrudedAreaSolid of an IfcRectangleProfileDef in an
/// IfcLocalPlacement chain (site -> building -> storey -> element -> opening -> filling). Doors
/// and windows are IfcDoor / IfcWindow in IfcOpeningElement voids of their wall
/// (IfcRelVoidsElement + IfcRelFillsElement); rooms and corridor are IfcSpace. Units are metres.
///
/// @note A door is modelled as a closed leaf (4 cm) and a window as a 6 cm pane, both in the
///       middle of the wall's thickness; a simulator that wants doors open or windows transparent
///       skips those element types (the openings in the walls are real voids).

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "plumb/core/types.hpp"

namespace plumb::bim {

/// @brief Settings of make_demo_building(). Lengths in metres.
struct DemoBuildingSettings {
  double length = 30.0;                  ///< outer length along x [m]
  double width = 15.0;                   ///< outer width along y [m]
  int num_storeys = 1;                   ///< storeys stacked with the same plan, >= 1
  int num_rooms = 8;                     ///< rooms per storey off the corridor, >= 1
  double storey_height = 3.2;            ///< floor-to-floor height [m]
  double slab_thickness = 0.25;          ///< floor and roof slabs [m]
  double exterior_wall_thickness = 0.3;  ///< [m]
  double interior_wall_thickness = 0.12; ///< corridor and partition walls [m]
  double corridor_width = 2.0;           ///< clear width between the corridor walls [m]
  double min_room_width = 2.5;           ///< smallest clear room width along the corridor [m]
  double room_width_jitter = 0.15;       ///< room widths vary by up to this fraction of the mean
  double door_width = 1.0;               ///< clear door opening, >= 0.9 [m]
  double door_height = 2.1;              ///< [m]
  double entrance_width = 1.6;           ///< entrance opening at the west end of the corridor; 0: none [m]
  double window_width = 1.5;             ///< [m]
  double window_height = 1.3;            ///< [m]
  double window_sill = 0.9;              ///< sill height above the floor [m]
  double column_size = 0.4;              ///< square columns at partition / exterior wall junctions; 0: none [m]
  std::uint64_t seed = 1;                ///< room widths, door positions and GUIDs
  std::string name = "plumb demo office";  ///< building name (also the file's project name)
  std::string file_name = "demo_office.ifc";  ///< FILE_NAME written in the header (not a path)
};

/// @brief One room, the corridor, or any other space in the plan: its clear floor rectangle.
struct DemoSpace {
  std::string name;       ///< "Room 1", ..., "Corridor"
  int storey = 0;         ///< storey index (0 = ground)
  Vector2d min = Vector2d::Zero();  ///< clear floor rectangle, building frame [m]
  Vector2d max = Vector2d::Zero();  ///< [m]
  double area() const { return (max - min).prod(); }
};

/// @brief The generated file and what it contains.
struct DemoBuildingResult {
  std::string ifc;                  ///< the IFC4 file text
  std::vector<DemoSpace> spaces;    ///< rooms then corridor, per storey
  std::size_t num_walls = 0;        ///< IfcWall
  std::size_t num_doors = 0;        ///< IfcDoor (room doors + entrance)
  std::size_t num_windows = 0;      ///< IfcWindow
  std::size_t num_slabs = 0;        ///< IfcSlab (floors + roof)
  std::size_t num_columns = 0;      ///< IfcColumn
  double gross_floor_area = 0.0;    ///< length * width per storey, summed [m^2]
};

/// @brief Generate the demo office building.
/// @return the IFC text and a summary; same settings -> byte-identical text.
/// @throws plumb::Error naming the setting when the settings are unusable: non-positive or
///         non-finite sizes, rooms that do not fit (clear width below min_room_width), doors
///         narrower than 0.9 m or wider than a room, windows or doors taller than the storey.
DemoBuildingResult make_demo_building(const DemoBuildingSettings& settings = {});

/// @brief make_demo_building() and write its text to `path`.
/// @throws plumb::Error on bad settings or when the file cannot be written.
DemoBuildingResult write_demo_building(const std::string& path, const DemoBuildingSettings& settings = {});

}  // namespace plumb::bim
