// SPDX-License-Identifier: BSD-3-Clause
// The procedural demo office: reads back through our reader and mesher without warnings, has the
// elements the settings ask for in the places they should be, agrees with web-ifc's geometry, and
// the committed examples/data/demo_office.ifc is what the generator writes today.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "plumb/bim/demo_building.hpp"
#include "plumb/bim/mesh.hpp"
#include "plumb/core/error.hpp"
#include "test_data.hpp"

namespace plumb::bim {
namespace {

struct Built {
  DemoBuildingResult result;
  IfcModel model;
  BimMesh mesh;
};

Built build(const DemoBuildingSettings& s, bool include_spaces = false) {
  DemoBuildingResult r = make_demo_building(s);
  IfcModel m = parse_ifc(r.ifc, "demo");
  BimMeshSettings ms;
  ms.include_spaces = include_spaces;
  BimMesh mesh = build_mesh(m, ms);
  return {std::move(r), std::move(m), std::move(mesh)};
}

std::map<std::string, int> count_types(const BimMesh& mesh) {
  std::map<std::string, int> n;
  for (const auto& e : mesh.elements) ++n[e.type];
  return n;
}

const BimElement& element(const BimMesh& mesh, std::uint32_t id) {
  const int k = mesh.find_element(id);
  if (k < 0) throw std::runtime_error("no element #" + std::to_string(id));
  return mesh.elements[static_cast<std::size_t>(k)];
}

/// Does the segment p -> q cross a triangle of element `e` (Moller-Trumbore, interior hits only)?
bool segment_hits(const BimMesh& mesh, const BimElement& e, const Vector3d& p, const Vector3d& q) {
  const Vector3d d = q - p;
  for (std::size_t t = e.first_triangle; t < e.first_triangle + e.num_triangles; ++t) {
    const Vector3d& a = mesh.vertices[mesh.triangles[t][0]];
    const Vector3d& b = mesh.vertices[mesh.triangles[t][1]];
    const Vector3d& c = mesh.vertices[mesh.triangles[t][2]];
    const Vector3d e1 = b - a, e2 = c - a;
    const Vector3d h = d.cross(e2);
    const double det = e1.dot(h);
    if (std::abs(det) < 1e-15) continue;
    const Vector3d s = p - a;
    const double u = s.dot(h) / det;
    if (u < 0.0 || u > 1.0) continue;
    const Vector3d qq = s.cross(e1);
    const double v = d.dot(qq) / det;
    if (v < 0.0 || u + v > 1.0) continue;
    const double t_hit = e2.dot(qq) / det;
    if (t_hit >= 0.0 && t_hit <= 1.0) return true;
  }
  return false;
}

template <typename F>
void expect_error_naming(F&& f, const std::string& needle) {
  try {
    f();
    ADD_FAILURE() << "expected plumb::Error mentioning '" << needle << "'";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
  }
}

TEST(DemoBuildingTest, ReadsBackWithoutWarnings) {
  const Built b = build({});
  EXPECT_EQ(b.model.step.schema_name(), "IFC4");
  EXPECT_EQ(b.model.units.length_to_m, 1.0);
  EXPECT_TRUE(b.model.warnings.empty()) << b.model.warnings.front();
  EXPECT_TRUE(b.mesh.warnings.empty()) << b.mesh.warnings.front();
  for (const auto& e : b.mesh.elements) {
    EXPECT_GT(e.num_triangles, 0u) << e.type << " " << e.name;
    EXPECT_EQ(e.global_id.size(), 22u) << e.name;
  }
  // Gross size: the mesh spans length x width and one storey height (floor slab below z = 0).
  Vector3d lo, hi;
  b.mesh.bounds(lo, hi);
  EXPECT_NEAR(lo.x(), 0.0, 1e-9);
  EXPECT_NEAR(lo.y(), 0.0, 1e-9);
  EXPECT_NEAR(hi.x(), 30.0, 1e-9);
  EXPECT_NEAR(hi.y(), 15.0, 1e-9);
  EXPECT_NEAR(lo.z(), -0.25, 1e-9);
  EXPECT_NEAR(hi.z(), 3.2, 1e-9);
}

TEST(DemoBuildingTest, ElementCountsFollowTheSettings) {
  struct Case {
    int rooms, storeys;
    double entrance, column;
  };
  for (const Case c : {Case{8, 1, 1.6, 0.4}, Case{5, 1, 0.0, 0.0}, Case{6, 2, 1.2, 0.3}, Case{2, 1, 1.0, 0.4}}) {
    DemoBuildingSettings s;
    s.num_rooms = c.rooms;
    s.num_storeys = c.storeys;
    s.entrance_width = c.entrance;
    s.column_size = c.column;
    const Built b = build(s);
    SCOPED_TRACE("rooms " + std::to_string(c.rooms) + ", storeys " + std::to_string(c.storeys));
    EXPECT_TRUE(b.mesh.warnings.empty());
    auto n = count_types(b.mesh);
    const int entrance = c.entrance > 0 ? 1 : 0;
    // Per storey: 4 exterior + 2 corridor walls + a partition between neighbours in each row.
    const int walls = c.storeys * (4 + 2 + (c.rooms - 2));
    const int doors = c.storeys * c.rooms + entrance;
    const int windows = c.storeys * (c.rooms + 2) - entrance;  // one per room, both corridor ends
    const int columns = c.column > 0 ? c.storeys * (c.rooms - 2) : 0;
    EXPECT_EQ(n["IfcWall"], walls);
    EXPECT_EQ(n["IfcDoor"], doors);
    EXPECT_EQ(n["IfcWindow"], windows);
    EXPECT_EQ(n["IfcSlab"], c.storeys + 1);
    EXPECT_EQ(n["IfcColumn"], columns);
    EXPECT_EQ(b.mesh.elements.size(), static_cast<std::size_t>(walls + doors + windows + c.storeys + 1 + columns));
    EXPECT_EQ(b.result.num_walls, static_cast<std::size_t>(walls));
    EXPECT_EQ(b.result.num_doors, static_cast<std::size_t>(doors));
    EXPECT_EQ(b.result.num_windows, static_cast<std::size_t>(windows));
    EXPECT_EQ(b.result.num_columns, static_cast<std::size_t>(columns));
    EXPECT_EQ(b.result.spaces.size(), static_cast<std::size_t>(c.storeys * (c.rooms + 1)));
    EXPECT_EQ(b.model.step.ids_of_type("IFCSPACE").size(), static_cast<std::size_t>(c.storeys * (c.rooms + 1)));
    // Storeys at multiples of the storey height; every element sits in one.
    ASSERT_EQ(b.mesh.storeys.size(), static_cast<std::size_t>(c.storeys));
    for (int k = 0; k < c.storeys; ++k) {
      EXPECT_NEAR(b.mesh.storeys[static_cast<std::size_t>(k)].elevation, k * s.storey_height, 1e-12);
    }
    for (const auto& e : b.mesh.elements) {
      ASSERT_GE(e.storey, 0) << e.name;
      const double z0 = b.mesh.storeys[static_cast<std::size_t>(e.storey)].elevation;
      EXPECT_GE(e.bbox_min.z(), z0 - s.slab_thickness - 1e-9) << e.name;
      EXPECT_LE(e.bbox_max.z(), z0 + s.storey_height + 1e-9) << e.name;
    }
  }
}

TEST(DemoBuildingTest, EveryDoorAndWindowFillsAnOpeningThroughItsWall) {
  const DemoBuildingSettings s;
  const Built b = build(s);
  const StepFile& f = b.model.step;
  std::map<std::uint32_t, std::uint32_t> opening_of, wall_of;  // filling -> opening, opening -> wall
  for (std::uint32_t r : f.ids_of_type("IFCRELFILLSELEMENT")) {
    const auto a = f.args(r);
    opening_of[a[5].ref] = a[4].ref;
  }
  for (std::uint32_t r : f.ids_of_type("IFCRELVOIDSELEMENT")) {
    const auto a = f.args(r);
    wall_of[a[5].ref] = a[4].ref;
  }
  std::size_t checked = 0;
  for (const char* type : {"IFCDOOR", "IFCWINDOW"}) {
    for (std::uint32_t id : f.ids_of_type(type)) {
      ASSERT_TRUE(opening_of.count(id)) << type << " #" << id << " fills no opening";
      const std::uint32_t opening = opening_of[id];
      EXPECT_EQ(f.type_of(opening), "IFCOPENINGELEMENT");
      ASSERT_TRUE(wall_of.count(opening)) << "opening #" << opening << " voids no element";
      const std::uint32_t wall_id = wall_of[opening];
      EXPECT_EQ(f.type_of(wall_id), "IFCWALL");
      const BimElement& fill = element(b.mesh, id);
      const BimElement& wall = element(b.mesh, wall_id);
      // The panel lies inside the wall's box ...
      EXPECT_TRUE((fill.bbox_min.array() >= wall.bbox_min.array() - 1e-9).all()) << fill.name;
      EXPECT_TRUE((fill.bbox_max.array() <= wall.bbox_max.array() + 1e-9).all()) << fill.name;
      // ... and the wall has a hole there: a segment across the wall through the middle of the
      // panel meets no wall triangle, one 0.15 m beside the panel does.
      const Vector3d c = 0.5 * (fill.bbox_min + fill.bbox_max);
      const Vector3d ext = fill.bbox_max - fill.bbox_min;
      const int across = (wall.bbox_max - wall.bbox_min).x() < (wall.bbox_max - wall.bbox_min).y() ? 0 : 1;
      const int along = 1 - across;
      Vector3d p = c, q = c;
      p[across] = wall.bbox_min[across] - 0.05;
      q[across] = wall.bbox_max[across] + 0.05;
      EXPECT_FALSE(segment_hits(b.mesh, wall, p, q)) << "no hole in " << wall.name << " for " << fill.name;
      Vector3d shift = Vector3d::Zero();
      shift[along] = 0.5 * ext[along] + 0.15;
      EXPECT_TRUE(segment_hits(b.mesh, wall, p + shift, q + shift)) << wall.name << " beside " << fill.name;
      if (std::string(type) == "IFCDOOR") {
        EXPECT_GE(ext[along], 0.9 - 1e-9) << fill.name;  // doors at least 0.9 m wide
        EXPECT_NEAR(fill.bbox_min.z(), 0.0, 1e-9) << fill.name;
        EXPECT_NEAR(ext.z(), s.door_height, 1e-9) << fill.name;
      } else {
        EXPECT_NEAR(fill.bbox_min.z(), s.window_sill, 1e-9) << fill.name;
      }
      ++checked;
    }
  }
  EXPECT_EQ(checked, 9u + 9u);
}

TEST(DemoBuildingTest, RoomsOpenOntoTheCorridorAndWindowsAreInExteriorWalls) {
  DemoBuildingSettings s;
  s.seed = 99;
  const Built b = build(s, true);
  std::vector<const BimElement*> rooms, doors, windows;
  const BimElement* corridor = nullptr;
  for (const auto& e : b.mesh.elements) {
    if (e.type == "IfcSpace") {
      if (e.name == "Corridor") {
        corridor = &e;
      } else {
        rooms.push_back(&e);
      }
    } else if (e.type == "IfcDoor") {
      doors.push_back(&e);
    } else if (e.type == "IfcWindow") {
      windows.push_back(&e);
    }
  }
  ASSERT_NE(corridor, nullptr);
  ASSERT_EQ(rooms.size(), static_cast<std::size_t>(s.num_rooms));
  const double te = s.exterior_wall_thickness;
  EXPECT_NEAR(corridor->bbox_max.y() - corridor->bbox_min.y(), s.corridor_width, 1e-9);
  for (const BimElement* r : rooms) {
    SCOPED_TRACE(r->name);
    EXPECT_GE(r->bbox_max.x() - r->bbox_min.x(), s.min_room_width - 1e-9);
    EXPECT_GE(r->bbox_min.x(), te - 1e-9);
    EXPECT_LE(r->bbox_max.x(), s.length - te + 1e-9);
    // Exactly one door whose span along the corridor lies within the room and which sits in the
    // wall between the room and the corridor.
    int room_doors = 0;
    for (const BimElement* d : doors) {
      const bool within = d->bbox_min.x() >= r->bbox_min.x() - 1e-9 && d->bbox_max.x() <= r->bbox_max.x() + 1e-9;
      const bool south_room = r->bbox_max.y() < corridor->bbox_min.y();
      const bool between = south_room ? (d->bbox_min.y() >= r->bbox_max.y() - 1e-9 && d->bbox_max.y() <= corridor->bbox_min.y() + 1e-9)
                                      : (d->bbox_min.y() >= corridor->bbox_max.y() - 1e-9 && d->bbox_max.y() <= r->bbox_min.y() + 1e-9);
      if (within && between) ++room_doors;
    }
    EXPECT_EQ(room_doors, 1);
    // Rooms do not overlap.
    for (const BimElement* o : rooms) {
      if (o == r) continue;
      const bool overlap = (r->bbox_min.head<2>().array() < o->bbox_max.head<2>().array() - 1e-9).all() &&
                           (o->bbox_min.head<2>().array() < r->bbox_max.head<2>().array() - 1e-9).all();
      EXPECT_FALSE(overlap) << o->name;
    }
  }
  for (const BimElement* w : windows) {  // every window in the outer shell of the building
    const bool in_shell = w->bbox_max.y() <= te + 1e-9 || w->bbox_min.y() >= s.width - te - 1e-9 ||
                          w->bbox_max.x() <= te + 1e-9 || w->bbox_min.x() >= s.length - te - 1e-9;
    EXPECT_TRUE(in_shell) << w->name;
  }
}

TEST(DemoBuildingTest, FloorAreaMatchesTheSettings) {
  DemoBuildingSettings s;
  s.length = 24.0;
  s.width = 13.0;
  s.num_rooms = 6;
  const Built b = build(s, true);
  double slab_top = 0.0, spaces = 0.0;
  for (const auto& e : b.mesh.elements) {
    if (e.type == "IfcSpace") spaces += (e.bbox_max - e.bbox_min).head<2>().prod();
    if (e.type != "IfcSlab" || e.name != "Floor slab") continue;
    for (std::size_t t = e.first_triangle; t < e.first_triangle + e.num_triangles; ++t) {
      const Vector3d& p = b.mesh.vertices[b.mesh.triangles[t][0]];
      const Vector3d n = (b.mesh.vertices[b.mesh.triangles[t][1]] - p).cross(b.mesh.vertices[b.mesh.triangles[t][2]] - p);
      if (n.z() > 0 && std::abs(p.z()) < 1e-9) slab_top += 0.5 * n.norm();  // upward faces at z = 0
    }
  }
  EXPECT_NEAR(slab_top, s.length * s.width, 1e-9);
  EXPECT_NEAR(b.result.gross_floor_area, s.length * s.width, 1e-9);
  // Net floor: inside the exterior walls, less the two corridor walls; partitions take ~1 % more.
  const double inner = (s.length - 2 * s.exterior_wall_thickness) * (s.width - 2 * s.exterior_wall_thickness);
  const double net = inner - 2 * s.interior_wall_thickness * (s.length - 2 * s.exterior_wall_thickness);
  EXPECT_LE(spaces, net + 1e-6);
  EXPECT_GE(spaces, 0.97 * net);
}

TEST(DemoBuildingTest, SameSettingsSameBytes) {
  DemoBuildingSettings s;
  const std::string a = make_demo_building(s).ifc;
  EXPECT_EQ(a, make_demo_building(s).ifc);
  s.seed = 2;
  const DemoBuildingResult other = make_demo_building(s);
  EXPECT_NE(a, other.ifc);
  // Another seed moves partitions and doors but keeps the counts.
  const DemoBuildingResult first = make_demo_building({});
  EXPECT_EQ(other.num_doors, first.num_doors);
  bool moved = false;
  for (std::size_t k = 0; k < first.spaces.size(); ++k) moved = moved || first.spaces[k].max != other.spaces[k].max;
  EXPECT_TRUE(moved);
}

TEST(DemoBuildingTest, CommittedExampleIsWhatTheGeneratorWrites) {
  const std::string path = test::source_dir() + "/examples/data/demo_office.ifc";
  std::ifstream in(path, std::ios::binary);
  ASSERT_TRUE(in.good()) << path;
  std::ostringstream ss;
  ss << in.rdbuf();
  EXPECT_TRUE(ss.str() == make_demo_building({}).ifc)
      << path << " is stale: regenerate it with `plumb make-demo-building -o " << path
      << "` and its web-ifc golden with scripts/ifc_golden/make_demo_golden.sh";
}

TEST(DemoBuildingTest, BoxesMatchWebIfc) {
  // Golden made by scripts/ifc_golden/webifc_bbox.cjs from examples/data/demo_office.ifc.
  const std::string golden_path = test::source_dir() + "/tests/bim/golden/demo_office_webifc_bbox.json";
  std::ifstream in(golden_path);
  ASSERT_TRUE(in.good()) << golden_path;
  const nlohmann::json golden = nlohmann::json::parse(in);
  const BimMesh mesh = build_mesh(read_ifc(test::source_dir() + "/examples/data/demo_office.ifc"));
  // web-ifc meshed every wall, slab, door, window and column.
  EXPECT_EQ(golden["elements"].size(), mesh.elements.size());
  for (const auto& [id_text, ref] : golden["elements"].items()) {
    const BimElement& el = element(mesh, static_cast<std::uint32_t>(std::stoul(id_text)));
    std::string type = el.type;
    for (char& ch : type) ch = static_cast<char>(std::toupper(static_cast<unsigned char>(ch)));
    EXPECT_EQ(type, ref["type"].get<std::string>()) << el.name;
    for (int c = 0; c < 3; ++c) {
      EXPECT_NEAR(el.bbox_min[c], ref["bbox"][0][c].get<double>(), 1e-3) << el.name << " min axis " << c;
      EXPECT_NEAR(el.bbox_max[c], ref["bbox"][1][c].get<double>(), 1e-3) << el.name << " max axis " << c;
    }
  }
}

double element_area(const BimMesh& mesh, const BimElement& e) {
  double a = 0.0;
  for (std::size_t t = e.first_triangle; t < e.first_triangle + e.num_triangles; ++t) {
    const Vector3d& p = mesh.vertices[mesh.triangles[t][0]];
    a += 0.5 * (mesh.vertices[mesh.triangles[t][1]] - p).cross(mesh.vertices[mesh.triangles[t][2]] - p).norm();
  }
  return a;
}

TEST(DemoBuildingTest, SurfaceAreasMatchWebIfc) {
  // Golden made by scripts/ifc_golden/webifc_area.cjs. Elements without openings must match
  // exactly. A wall with openings: web-ifc's boolean difference adds the reveal faces inside each
  // opening (perimeter x wall thickness) that build_mesh, which clips the wall's own faces, does not
  // add; the difference must stay within those reveals (an opening not cut at all would leave the
  // wall larger than web-ifc's by its two face areas, which is more).
  const std::string golden_path = test::source_dir() + "/tests/bim/golden/demo_office_webifc_area.json";
  std::ifstream in(golden_path);
  ASSERT_TRUE(in.good()) << golden_path;
  const nlohmann::json golden = nlohmann::json::parse(in);
  const IfcModel model = read_ifc(test::source_dir() + "/examples/data/demo_office.ifc");
  const BimMesh mesh = build_mesh(model);
  const StepFile& f = model.step;
  std::map<std::uint32_t, double> reveal;  // wall id -> reveal area of its openings
  std::map<std::uint32_t, std::uint32_t> wall_of;
  for (std::uint32_t r : f.ids_of_type("IFCRELVOIDSELEMENT")) wall_of[f.args(r)[5].ref] = f.args(r)[4].ref;
  for (std::uint32_t r : f.ids_of_type("IFCRELFILLSELEMENT")) {
    const std::uint32_t wall_id = wall_of.at(f.args(r)[4].ref);
    const BimElement& fill = element(mesh, f.args(r)[5].ref);
    const BimElement& wall = element(mesh, wall_id);
    const Vector3d wext = wall.bbox_max - wall.bbox_min, fext = fill.bbox_max - fill.bbox_min;
    const double thickness = std::min(wext.x(), wext.y());
    const double width = std::max(fext.x(), fext.y());
    const bool bottom = fill.bbox_min.z() > wall.bbox_min.z() + 1e-9;  // a door's opening has no sill face
    reveal[wall_id] += (2.0 * fext.z() + width * (bottom ? 2.0 : 1.0)) * thickness;
  }
  EXPECT_EQ(reveal.size(), 6u);  // 4 exterior walls (windows, entrance) and the 2 corridor walls
  std::size_t compared = 0;
  for (const auto& [id_text, ref] : golden["elements"].items()) {
    const auto id = static_cast<std::uint32_t>(std::stoul(id_text));
    const BimElement& el = element(mesh, id);
    const double ours = element_area(mesh, el), theirs = ref["area"].get<double>();
    const double allowed = reveal.count(id) ? reveal[id] : 0.0;
    EXPECT_LE(std::abs(ours - theirs), allowed + 1e-4) << el.name << ": plumb " << ours << " m^2, web-ifc " << theirs;
    ++compared;
  }
  EXPECT_EQ(compared, mesh.elements.size());
}

TEST(DemoBuildingTest, BadSettingsThrow) {
  auto with = [](auto edit) {
    DemoBuildingSettings s;
    edit(s);
    return [s] { make_demo_building(s); };
  };
  expect_error_naming(with([](DemoBuildingSettings& s) { s.length = 0.0; }), "length");
  expect_error_naming(with([](DemoBuildingSettings& s) { s.width = -3.0; }), "width");
  expect_error_naming(with([](DemoBuildingSettings& s) { s.storey_height = std::nan(""); }), "storey_height");
  expect_error_naming(with([](DemoBuildingSettings& s) { s.num_rooms = 40; }), "rooms do not fit");
  expect_error_naming(with([](DemoBuildingSettings& s) { s.num_rooms = 1; }), "num_rooms");
  expect_error_naming(with([](DemoBuildingSettings& s) { s.num_storeys = 0; }), "num_storeys");
  expect_error_naming(with([](DemoBuildingSettings& s) { s.door_width = 0.8; }), "door_width");
  expect_error_naming(with([](DemoBuildingSettings& s) { s.door_height = 3.0; }), "door_height");
  expect_error_naming(with([](DemoBuildingSettings& s) { s.window_sill = 2.0; }), "window");
  expect_error_naming(with([](DemoBuildingSettings& s) { s.width = 8.0; }), "width");
  expect_error_naming(with([](DemoBuildingSettings& s) { s.entrance_width = 2.5; }), "entrance_width");
  expect_error_naming(with([](DemoBuildingSettings& s) { s.slab_thickness = 4.0; }), "slab_thickness");
  EXPECT_THROW(write_demo_building("/nonexistent-dir/demo.ifc"), Error);
}

}  // namespace
}  // namespace plumb::bim
