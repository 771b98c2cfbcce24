// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/bim/floor_plan.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "plumb/bim/ifc.hpp"
#include "plumb/core/error.hpp"
#include "plumb/sim/route.hpp"
#include "model_variants.hpp"
#include "test_data.hpp"

namespace plumb::bim {
namespace {

/// Appends an axis-aligned box as one element (12 triangles).
void add_box(BimMesh& mesh, const Vector3d& lo, const Vector3d& hi, const std::string& type, int storey = 0) {
  BimElement e;
  e.type = type;
  e.storey = storey;
  e.first_triangle = mesh.triangles.size();
  e.num_triangles = 12;
  e.bbox_min = lo;
  e.bbox_max = hi;
  e.has_body = true;
  const auto base = static_cast<std::uint32_t>(mesh.vertices.size());
  for (int k = 0; k < 8; ++k) {
    mesh.vertices.emplace_back((k & 1) ? hi.x() : lo.x(), (k & 2) ? hi.y() : lo.y(), (k & 4) ? hi.z() : lo.z());
  }
  const std::uint32_t faces[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& f : faces) {
    mesh.triangles.push_back({base + f[0], base + f[1], base + f[2]});
    mesh.triangles.push_back({base + f[0], base + f[2], base + f[3]});
  }
  const auto index = static_cast<std::int32_t>(mesh.elements.size());
  mesh.triangle_element.insert(mesh.triangle_element.end(), 12, index);
  mesh.elements.push_back(e);
}

/// 12 m x 8 m floor, 0.2 m walls 2.8 m high, three rooms joined by two doorways holding IfcDoor leaves.
BimMesh three_rooms(bool with_floor = true) {
  BimMesh m;
  m.storeys.push_back({1, "Ground", 0.0});
  if (with_floor) add_box(m, {0, 0, -0.2}, {12, 8, 0}, "IfcSlab");
  add_box(m, {0, 0, 0}, {12, 0.2, 2.8}, "IfcWallStandardCase");
  add_box(m, {0, 7.8, 0}, {12, 8, 2.8}, "IfcWallStandardCase");
  add_box(m, {0, 0, 0}, {0.2, 8, 2.8}, "IfcWallStandardCase");
  add_box(m, {11.8, 0, 0}, {12, 8, 2.8}, "IfcWallStandardCase");
  // x = 6 wall with a doorway y in [3, 4]
  add_box(m, {5.9, 0, 0}, {6.1, 3, 2.8}, "IfcWallStandardCase");
  add_box(m, {5.9, 4, 0}, {6.1, 8, 2.8}, "IfcWallStandardCase");
  add_box(m, {5.9, 3, 2.1}, {6.1, 4, 2.8}, "IfcWallStandardCase");  // lintel above the door
  add_box(m, {5.98, 3, 0}, {6.02, 4, 2.1}, "IfcDoor");
  // y = 4 wall in the right half with a doorway x in [8.5, 9.5]
  add_box(m, {6, 3.9, 0}, {8.5, 4.1, 2.8}, "IfcWall");
  add_box(m, {9.5, 3.9, 0}, {12, 4.1, 2.8}, "IfcWall");
  add_box(m, {8.5, 3.98, 0}, {9.5, 4.02, 2.1}, "IfcDoor");
  // a table in the left room: its top (0.72..0.75) is in the slice, so it blocks
  add_box(m, {2, 5, 0.72}, {3, 6, 0.75}, "IfcFurnishingElement");
  return m;
}

TEST(FloorPlanTest, SliceOfThreeRooms) {
  const BimMesh mesh = three_rooms();
  OccupancyGridSettings s;
  s.resolution = 0.05;
  const OccupancyGrid g = floor_plan(mesh, s);
  EXPECT_EQ(g.storey, 0);
  EXPECT_EQ(g.floor_z, 0.0);
  EXPECT_TRUE(g.is_free({3.0, 2.0}));      // left room
  EXPECT_TRUE(g.is_free({9.0, 2.0}));      // lower right room
  EXPECT_TRUE(g.is_free({9.0, 6.0}));      // upper right room
  EXPECT_TRUE(g.is_free({6.0, 3.5}));      // doorway, door open
  EXPECT_TRUE(g.is_free({9.0, 4.0}));      // doorway
  EXPECT_FALSE(g.is_free({6.0, 1.5}));     // wall
  EXPECT_FALSE(g.is_free({0.1, 4.0}));     // outer wall
  EXPECT_FALSE(g.is_free({2.5, 5.5}));     // under the table top
  const Eigen::Vector2i wall = g.cell_of({6.0, 6.0});
  EXPECT_EQ(g.at(wall.x(), wall.y()), CellState::kOccupied);
  const Eigen::Vector2i out = g.cell_of({-0.5, 4.0});
  EXPECT_EQ(g.at(out.x(), out.y()), CellState::kOutside);
  EXPECT_EQ(g.at(-1, 0), CellState::kOutside);
  // Free area: the inner 11.6 x 7.6 m minus the interior walls and the table (+ the two doorways),
  // give or take one cell along every wall face.
  const double expected = 11.6 * 7.6 - 0.2 * 7.6 - 0.2 * 5.7 - 1.0 + 2 * 0.2;
  const double boundary = (2 * 11.6 + 2 * 7.6 + 2 * 7.6 + 2 * 5.7 + 4.0) * s.resolution;
  EXPECT_NEAR(g.free_area(), expected, boundary);
}

TEST(FloorPlanTest, DoorsAreOpenOnlyWhenIgnored) {
  const BimMesh mesh = three_rooms();
  OccupancyGridSettings s;
  const OccupancyGrid open = floor_plan(mesh, s);
  const std::vector<float> clr_open = sim::clearance_map(open);
  sim::RouteSettings rs;
  rs.min_clearance = 0.3;
  EXPECT_FALSE(sim::plan_path(open, clr_open, {3, 2}, {9, 6}, rs).empty());
  s.ignored_types = {"IfcSpace"};  // doors now block
  const OccupancyGrid closed = floor_plan(mesh, s);
  EXPECT_FALSE(closed.is_free({6.0, 3.5}));
  EXPECT_TRUE(sim::plan_path(closed, sim::clearance_map(closed), {3, 2}, {9, 6}, rs).empty());
}

// Without any floor surface (as in exports whose slab is in the structural model), the floor is
// what the walls and doors enclose: the same free cells as with the slab, give or take the cells
// along the outer walls' faces.
TEST(FloorPlanTest, WithoutAFloorTheWallsEncloseIt) {
  const OccupancyGrid slab = floor_plan(three_rooms(true));
  const OccupancyGrid walls = floor_plan(three_rooms(false));
  EXPECT_EQ(slab.floor_source, FloorSource::kSurfaces);
  EXPECT_EQ(walls.floor_source, FloorSource::kWalls);
  EXPECT_TRUE(walls.has_doors);
  ASSERT_EQ(walls.cells.size(), slab.cells.size());
  std::size_t both = 0, either = 0;
  for (std::size_t i = 0; i < slab.cells.size(); ++i) {
    const bool a = slab.cells[i] == CellState::kFree, b = walls.cells[i] == CellState::kFree;
    both += a && b ? 1 : 0;
    either += a || b ? 1 : 0;
  }
  EXPECT_GT(static_cast<double>(both) / static_cast<double>(either), 0.97);
  EXPECT_TRUE(walls.is_free({6.0, 3.5}));   // the doorways stay open for the robot
  EXPECT_FALSE(walls.is_free({-0.5, 4.0}));  // outside
  EXPECT_FALSE(walls.is_free({2.5, 5.5}));   // under the table

  // A gap wider than enclosure_gap in an outer wall (here 1 m, no door in it) lets the outside in.
  BimMesh open = three_rooms(false);
  open.triangles.clear();
  open.triangle_element.clear();
  open.elements.clear();
  open.vertices.clear();
  add_box(open, {0, 0, 0}, {5, 0.2, 2.8}, "IfcWallStandardCase");
  add_box(open, {6, 0, 0}, {12, 0.2, 2.8}, "IfcWallStandardCase");
  add_box(open, {0, 7.8, 0}, {12, 8, 2.8}, "IfcWallStandardCase");
  add_box(open, {0, 0, 0}, {0.2, 8, 2.8}, "IfcWallStandardCase");
  add_box(open, {11.8, 0, 0}, {12, 8, 2.8}, "IfcWallStandardCase");
  EXPECT_THROW(floor_plan(open), Error);
  OccupancyGridSettings wide;
  wide.enclosure_gap = 1.2;
  EXPECT_EQ(floor_plan(open, wide).floor_source, FloorSource::kWalls);
  EXPECT_NEAR(floor_plan(open, wide).free_area(), 11.6 * 7.6, 0.1 * 2 * (11.6 + 7.6));
}

TEST(FloorPlanTest, NoWalkableStoreyIsAClearError) {
  OccupancyGridSettings no_enclosure;
  no_enclosure.enclosure_gap = 0.0;
  const BimMesh no_floor = three_rooms(false);
  try {
    floor_plan(no_floor, no_enclosure);
    FAIL() << "expected plumb::Error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no walkable storey"), std::string::npos) << e.what();
  }
  BimMesh no_storey = three_rooms();
  no_storey.storeys.clear();
  EXPECT_THROW(floor_plan(no_storey), Error);
  OccupancyGridSettings s;
  s.storey = 3;
  EXPECT_THROW(floor_plan(three_rooms(), s), Error);
  // A storey placed 5 m above the only floor has no floor of its own.
  BimMesh two = three_rooms();
  two.storeys.push_back({2, "Roof", 5.0});
  s.storey = 1;
  try {
    floor_plan(two, s);
    FAIL() << "expected plumb::Error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("'Roof'"), std::string::npos) << e.what();
  }
  s.storey = -1;
  EXPECT_EQ(floor_plan(two, s).storey, 0);
  const std::vector<double> areas = storey_free_areas(two);
  ASSERT_EQ(areas.size(), 2u);
  EXPECT_GT(areas[0], 60.0);
  EXPECT_EQ(areas[1], 0.0);
  s.resolution = 0.0;
  EXPECT_THROW(floor_plan(two, s), Error);
}

TEST(FloorPlanTest, FzkHausFreeSpaceLiesInsideItsSpaces) {
  PLUMB_REQUIRE_DATA(path, "ifc/buildings/AC20-FZK-Haus.ifc");
  BimMeshSettings ms;
  ms.include_spaces = true;
  const BimMesh mesh = build_mesh(read_ifc(path), ms);
  const OccupancyGrid g = floor_plan(mesh);
  ASSERT_GE(g.storey, 0);
  // Independent reference: the IfcSpace volumes of that storey, which the architect drew as the
  // rooms. (Spaces are ignored by the slice.) Nearly every free cell must lie in a space footprint.
  std::vector<std::pair<Vector3d, Vector3d>> spaces;
  for (const BimElement& e : mesh.elements) {
    if (e.type == "IfcSpace" && e.storey == g.storey) spaces.emplace_back(e.bbox_min, e.bbox_max);
  }
  ASSERT_FALSE(spaces.empty());
  std::size_t free = 0, in_space = 0;
  for (int iy = 0; iy < g.height; ++iy) {
    for (int ix = 0; ix < g.width; ++ix) {
      if (g.at(ix, iy) != CellState::kFree) continue;
      ++free;
      const Vector2d c = g.center(ix, iy);
      for (const auto& [lo, hi] : spaces) {
        if (c.x() >= lo.x() && c.x() <= hi.x() && c.y() >= lo.y() && c.y() <= hi.y()) {
          ++in_space;
          break;
        }
      }
    }
  }
  EXPECT_GT(g.free_area(), 30.0);
  EXPECT_GT(static_cast<double>(in_space), 0.9 * static_cast<double>(free)) << in_space << " of " << free;
}

}  // namespace
}  // namespace plumb::bim

namespace plumb::bim {
namespace {

double free_iou(const OccupancyGrid& a, const OccupancyGrid& b) {
  std::size_t both = 0, either = 0;
  for (std::size_t i = 0; i < a.cells.size() && i < b.cells.size(); ++i) {
    const bool fa = a.cells[i] == CellState::kFree, fb = b.cells[i] == CellState::kFree;
    both += fa && fb ? 1 : 0;
    either += fa || fb ? 1 : 0;
  }
  return either > 0 ? static_cast<double>(both) / static_cast<double>(either) : 0.0;
}

// The shared models with their slabs and coverings taken out, as exports that leave the floors to
// the structural model: the storey a robot drives is found from its walls and doors, and its free
// cells are those of the model's own floor (independent reference: the slab that was taken out).
TEST(FloorPlanTest, SharedModelsWithoutFloorsAreWalkableFromTheirWalls) {
  struct Case {
    const char* file;
    int storey;         // the storey the full model drives on
    double min_iou;
  };
  for (const Case& c : {Case{"ifc/buildings/AC20-FZK-Haus.ifc", 0, 0.95}, Case{"ifc/buildings/duplex.ifc", 1, 0.55}}) {
    PLUMB_REQUIRE_DATA(path, c.file);
    const BimMesh mesh = build_mesh(read_ifc(path));
    const BimMesh bare = test::without_types(mesh, {"IfcSlab", "IfcCovering", "IfcRoof"});
    OccupancyGridSettings s;
    const OccupancyGrid full = floor_plan(mesh, s);
    ASSERT_EQ(full.storey, c.storey) << c.file;
    EXPECT_EQ(full.floor_source, FloorSource::kSurfaces) << c.file;
    const OccupancyGrid walls = floor_plan(bare, s);  // storey chosen as for a user: -1
    EXPECT_EQ(walls.storey, c.storey) << c.file << ": a storey with doors, not the foundation";
    EXPECT_EQ(walls.floor_source, FloorSource::kWalls) << c.file;
    EXPECT_GT(free_iou(full, walls), c.min_iou) << c.file;
    // Every free cell from the walls lies on the model's own floor or within 0.3 m of it.
    std::size_t off_floor = 0, free_cells = 0;
    for (int iy = 0; iy < walls.height; ++iy) {
      for (int ix = 0; ix < walls.width; ++ix) {
        if (walls.at(ix, iy) != CellState::kFree) continue;
        ++free_cells;
        bool near = false;
        for (int d = -6; d <= 6 && !near; ++d) {
          for (int e = -6; e <= 6 && !near; ++e) near = full.at(ix + d, iy + e) != CellState::kOutside;
        }
        off_floor += near ? 0 : 1;
      }
    }
    EXPECT_LT(static_cast<double>(off_floor), 0.01 * static_cast<double>(free_cells)) << c.file;
  }
}

TEST(FloorPlanTest, ModelledFloorsAreKeptOnEverySharedModel) {
  for (const char* file : {"ifc/buildings/AC20-FZK-Haus.ifc", "ifc/buildings/duplex.ifc",
                           "ifc/buildings/IfcOpenHouse_IFC4.ifc"}) {
    PLUMB_REQUIRE_DATA(path, file);
    const BimMesh mesh = build_mesh(read_ifc(path));
    const std::vector<double> areas = storey_free_areas(mesh);
    for (std::size_t k = 0; k < areas.size(); ++k) {
      if (areas[k] < 4.0) continue;
      OccupancyGridSettings s;
      s.storey = static_cast<int>(k);
      OccupancyGridSettings surfaces_only = s;
      surfaces_only.enclosure_gap = 0.0;
      const OccupancyGrid g = floor_plan(mesh, s);
      if (g.floor_source == FloorSource::kWalls) continue;  // a storey whose floor is not modelled
      EXPECT_EQ(g.cells, floor_plan(mesh, surfaces_only).cells) << file << " storey " << k;
    }
  }
}

}  // namespace
}  // namespace plumb::bim

namespace plumb::bim {
namespace {

// A stair flight of 1 m wide steps, 0.17 m rise, 0.3 m going, rising along +x from (x0, y0).
void add_stair(BimMesh& m, double x0, double y0, int steps, const std::string& type) {
  for (int k = 0; k < steps; ++k) {
    add_box(m, {x0 + 0.3 * k, y0, 0.0}, {x0 + 0.3 * (k + 1), y0 + 1.0, 0.17 * (k + 1)}, type);
  }
}

// A wheeled robot cannot climb a stair or a steep ramp: its first step (below the obstacle slice)
// is not floor, and neither is the rest of its footprint.
TEST(FloorPlanTest, StairsAreNotWalkable) {
  BimMesh m = three_rooms(true);
  add_stair(m, 1.0, 1.0, 6, "IfcStairFlight");
  const OccupancyGrid g = floor_plan(m);
  OccupancyGridSettings walkable_stairs;
  walkable_stairs.unwalkable_types.clear();
  const OccupancyGrid old = floor_plan(m, walkable_stairs);
  // Independent reference: the stair's footprint [1, 2.8] x [1, 2], cell centres strictly inside.
  std::size_t under = 0, free_with_default = 0, free_when_walkable = 0;
  for (int iy = 0; iy < g.height; ++iy) {
    for (int ix = 0; ix < g.width; ++ix) {
      const Vector2d c = g.center(ix, iy);
      if (c.x() <= 1.0 || c.x() >= 2.8 || c.y() <= 1.0 || c.y() >= 2.0) continue;
      ++under;
      free_with_default += g.at(ix, iy) == CellState::kFree ? 1 : 0;
      free_when_walkable += old.at(ix, iy) == CellState::kFree ? 1 : 0;
    }
  }
  ASSERT_GT(under, 500u);
  EXPECT_EQ(free_with_default, 0u);
  EXPECT_GT(free_when_walkable, 50u);  // the first step reads as floor when stairs are not singled out
  EXPECT_TRUE(g.is_free({3.5, 1.5}));   // beside the stair the floor is free
}

// The shared models' stairs: no free cell lies under a stair triangle crossing the floor band or
// the obstacle slice (brute force over the triangles).
TEST(FloorPlanTest, SharedModelsStairsAreOccupied) {
  for (const char* file : {"ifc/buildings/AC20-FZK-Haus.ifc", "ifc/buildings/duplex.ifc"}) {
    PLUMB_REQUIRE_DATA(path, file);
    const BimMesh mesh = build_mesh(read_ifc(path));
    const OccupancyGridSettings s;
    const OccupancyGrid g = floor_plan(mesh, s);
    const double lo = g.floor_z - s.floor_below, hi = g.floor_z + s.slice_max;
    std::size_t stair_triangles = 0, free_under = 0;
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
      const std::string& type = mesh.elements[static_cast<std::size_t>(mesh.triangle_element[t])].type;
      if (type != "IfcStair" && type != "IfcStairFlight") continue;
      const Vector3d& a = mesh.vertices[mesh.triangles[t][0]];
      const Vector3d& b = mesh.vertices[mesh.triangles[t][1]];
      const Vector3d& c = mesh.vertices[mesh.triangles[t][2]];
      if (std::max({a.z(), b.z(), c.z()}) < lo || std::min({a.z(), b.z(), c.z()}) > hi) continue;
      ++stair_triangles;
      const double area2 = (b - a).x() * (c - a).y() - (b - a).y() * (c - a).x();
      if (std::abs(area2) < 1e-9) continue;
      for (int iy = 0; iy < g.height; ++iy) {
        for (int ix = 0; ix < g.width; ++ix) {
          if (g.at(ix, iy) != CellState::kFree) continue;
          const Vector2d p = g.center(ix, iy);
          const double w0 = ((b - a).x() * (p - a.head<2>()).y() - (b - a).y() * (p - a.head<2>()).x()) / area2;
          const double w1 = ((p - a.head<2>()).x() * (c - a).y() - (p - a.head<2>()).y() * (c - a).x()) / area2;
          if (w0 >= 0.0 && w1 >= 0.0 && w0 + w1 <= 1.0) ++free_under;
        }
      }
    }
    EXPECT_GT(stair_triangles, 0u) << file;
    EXPECT_EQ(free_under, 0u) << file;
  }
}

// Rooms (IfcSpace) make the floor where no floor surface is modelled and the walls do not close
// (a glazed side, a missing wall): the walls' enclosure leaks, the rooms' footprints do not.
TEST(FloorPlanTest, RoomsMakeTheFloorWhereSlabsAreMissingAndWallsDoNotClose) {
  BimMesh m;
  m.storeys.push_back({1, "Ground", 0.0});
  add_box(m, {0, 0, 0}, {12, 0.2, 2.8}, "IfcWallStandardCase");
  add_box(m, {0, 0, 0}, {0.2, 8, 2.8}, "IfcWallStandardCase");
  add_box(m, {11.8, 0, 0}, {12, 8, 2.8}, "IfcWallStandardCase");  // no wall along y = 8
  add_box(m, {0.2, 0.2, 0.0}, {11.8, 8.0, 2.8}, "IfcSpace");
  add_box(m, {5, 3, 0}, {5.4, 3.4, 2.8}, "IfcColumn");
  const OccupancyGrid g = floor_plan(m);
  EXPECT_EQ(g.floor_source, FloorSource::kSpaces);
  EXPECT_FALSE(is_modelled(g.floor_source));
  EXPECT_STREQ(to_string(g.floor_source), "spaces");
  // The room's area less the column's, to the cells along their edges.
  EXPECT_NEAR(g.free_area(), 11.6 * 7.8 - 0.16, 0.05 * 2 * (11.6 + 7.8 + 0.8));
  EXPECT_FALSE(g.is_free({5.2, 3.2}));  // the column
  EXPECT_FALSE(g.is_free({6.0, 8.5}));  // beyond the open side
  // Without the room, the open side lets the outside in: no walkable floor.
  OccupancyGridSettings no_rooms;
  no_rooms.space_types.clear();
  EXPECT_THROW(floor_plan(m, no_rooms), Error);
}

// The shared models with their slabs, coverings and roofs taken out but their rooms kept (an
// architectural export without floors): the rooms make the driven storey's floor, and it matches
// the model's own floor (the independent reference: the slab that was taken out).
TEST(FloorPlanTest, SharedModelsWithRoomsButNoFloorsAreWalkableFromTheRooms) {
  for (const char* file : {"ifc/buildings/AC20-FZK-Haus.ifc", "ifc/buildings/duplex.ifc"}) {
    PLUMB_REQUIRE_DATA(path, file);
    const BimMesh mesh = build_mesh(read_ifc(path), mesh_settings_with_spaces());
    const OccupancyGrid full = floor_plan(mesh);
    ASSERT_EQ(full.floor_source, FloorSource::kSurfaces) << file;
    const BimMesh rooms_only = test::without_types(mesh, {"IfcSlab", "IfcCovering", "IfcRoof"});
    OccupancyGridSettings s;
    s.storey = full.storey;
    const OccupancyGrid rooms = floor_plan(rooms_only, s);
    EXPECT_EQ(rooms.floor_source, FloorSource::kSpaces) << file;
    // About as close to the model's floor as the walls' enclosure of the same storey (FZK-Haus:
    // 0.985 against 0.990; duplex: 0.680 against 0.680).
    const OccupancyGrid walls = floor_plan(test::without_types(rooms_only, {"IfcSpace"}), s);
    EXPECT_GE(free_iou(full, rooms), free_iou(full, walls) - 0.02) << file;
    EXPECT_GT(free_iou(full, rooms), 0.6) << file;
  }
}

// Slicing goes by height, not by the storey an element is filed under: an export that files every
// element under one storey gives the same floor plans.
TEST(FloorPlanTest, AnElementFiledUnderAnotherStoreyIsUsedWhereItsGeometryIs) {
  PLUMB_REQUIRE_DATA(path, "ifc/buildings/duplex.ifc");
  const BimMesh mesh = build_mesh(read_ifc(path));
  BimMesh misfiled = mesh;
  for (BimElement& e : misfiled.elements) e.storey = static_cast<int>(mesh.storeys.size()) - 1;
  for (std::size_t k = 0; k < mesh.storeys.size(); ++k) {
    OccupancyGridSettings s;
    s.storey = static_cast<int>(k);
    s.min_walkable_area = 0.0;
    EXPECT_EQ(floor_plan(misfiled, s).cells, floor_plan(mesh, s).cells) << "storey " << k;
  }
}

}  // namespace
}  // namespace plumb::bim
