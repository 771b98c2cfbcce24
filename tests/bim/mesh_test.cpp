// SPDX-License-Identifier: BSD-3-Clause
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include "plumb/bim/mesh.hpp"
#include "plumb/bim/sample.hpp"
#include "plumb/core/error.hpp"
#include "test_data.hpp"

using namespace plumb::bim;
using plumb::Vector3d;

namespace {

BimMesh mesh_of(const std::string& relative, const BimMeshSettings& settings = {}) {
  return build_mesh(read_ifc(plumb::test::data_path(relative)), settings);
}

/// Enclosed volume by the divergence theorem (exact for closed, consistently oriented meshes).
double volume_of(const BimMesh& m, int element = -1) {
  double v = 0.0;
  for (std::size_t t = 0; t < m.triangles.size(); ++t) {
    if (element >= 0 && m.triangle_element[t] != element) continue;
    const auto& tri = m.triangles[t];
    v += m.vertices[tri[0]].dot(m.vertices[tri[1]].cross(m.vertices[tri[2]])) / 6.0;
  }
  return v;
}

double area_of(const BimMesh& m, int element = -1) {
  double a = 0.0;
  for (std::size_t t = 0; t < m.triangles.size(); ++t) {
    if (element >= 0 && m.triangle_element[t] != element) continue;
    const auto& tri = m.triangles[t];
    a += 0.5 * (m.vertices[tri[1]] - m.vertices[tri[0]]).cross(m.vertices[tri[2]] - m.vertices[tri[0]]).norm();
  }
  return a;
}

/// A one-element IFC4 model in millimetres: a 1000 x 1000 x 2000 box at (x, 0, 0) with extra text.
std::string box_model(double x_mm, const std::string& extra = "", const std::string& rep_items = "#21") {
  return "ISO-10303-21;\nHEADER;\nFILE_DESCRIPTION(('x'),'2;1');\nFILE_NAME('b','',(''),(''),'','','');\n"
         "FILE_SCHEMA(('IFC4'));\nENDSEC;\nDATA;\n"
         "#1=IFCUNITASSIGNMENT((#2));\n#2=IFCSIUNIT(*,.LENGTHUNIT.,.MILLI.,.METRE.);\n"
         "#5=IFCCARTESIANPOINT((0.,0.,0.));\n#6=IFCDIRECTION((0.,0.,1.));\n"
         "#10=IFCBUILDINGELEMENTPROXY('g1',$,'P',$,$,#11,#13,$,$);\n"
         "#11=IFCLOCALPLACEMENT($,#12);\n#12=IFCAXIS2PLACEMENT3D(#14,$,$);\n#14=IFCCARTESIANPOINT((" +
         std::to_string(x_mm) + ",0.,0.));\n"
         "#13=IFCPRODUCTDEFINITIONSHAPE($,$,(#20));\n#20=IFCSHAPEREPRESENTATION($,'Body','SweptSolid',(" + rep_items +
         "));\n#21=IFCEXTRUDEDAREASOLID(#22,$,#6,2000.);\n#22=IFCRECTANGLEPROFILEDEF(.AREA.,$,$,1000.,1000.);\n" +
         extra + "ENDSEC;\nEND-ISO-10303-21;\n";
}

/// Enclosed volume measured from another origin: equal to volume_of() only for a closed surface.
double volume_from(const BimMesh& m, const Vector3d& origin, int element = -1) {
  double v = 0.0;
  for (std::size_t t = 0; t < m.triangles.size(); ++t) {
    if (element >= 0 && m.triangle_element[t] != element) continue;
    const auto& tri = m.triangles[t];
    const Vector3d a = m.vertices[tri[0]] - origin, b = m.vertices[tri[1]] - origin, c = m.vertices[tri[2]] - origin;
    v += a.dot(b.cross(c)) / 6.0;
  }
  return v;
}

/// Independent ray oracle: nearest Moeller-Trumbore hit over all triangles, infinity for none.
double ray_range(const BimMesh& m, const Vector3d& o, const Vector3d& d) {
  double best = std::numeric_limits<double>::infinity();
  for (const auto& t : m.triangles) {
    const Vector3d e1 = m.vertices[t[1]] - m.vertices[t[0]], e2 = m.vertices[t[2]] - m.vertices[t[0]];
    const Vector3d p = d.cross(e2);
    const double det = e1.dot(p);
    if (std::abs(det) < 1e-300) continue;
    const Vector3d s = o - m.vertices[t[0]];
    const double u = s.dot(p) / det;
    const Vector3d q = s.cross(e1);
    const double w = d.dot(q) / det;
    if (u < -1e-12 || w < -1e-12 || u + w > 1.0 + 1e-12) continue;
    const double r = e2.dot(q) / det;
    if (r > 1e-12 && r < best) best = r;
  }
  return best;
}

/// Points of an element's box (grown by 10 %) where the winding number of its surface is not
/// 0 or 1: none for a closed, consistently oriented surface; a gap (a missing reveal) shows up.
int num_fractional_windings(const BimMesh& m, int element, int samples) {
  const auto& el = m.elements[static_cast<std::size_t>(element)];
  const Vector3d lo = el.bbox_min - 0.1 * (el.bbox_max - el.bbox_min), hi = el.bbox_max + 0.1 * (el.bbox_max - el.bbox_min);
  int bad = 0;
  std::uint64_t state = 12345;
  auto uniform = [&state]() {  // splitmix64 -> [0, 1)
    std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return static_cast<double>((z ^ (z >> 31)) >> 11) * 0x1.0p-53;
  };
  for (int i = 0; i < samples; ++i) {
    const Vector3d p(lo.x() + uniform() * (hi.x() - lo.x()), lo.y() + uniform() * (hi.y() - lo.y()),
                     lo.z() + uniform() * (hi.z() - lo.z()));
    double w = 0.0;  // solid angles (Van Oosterom and Strackee 1983) / 4 pi
    for (std::size_t t = 0; t < m.triangles.size(); ++t) {
      if (m.triangle_element[t] != element) continue;
      const auto& tri = m.triangles[t];
      const Vector3d a = m.vertices[tri[0]] - p, b = m.vertices[tri[1]] - p, c = m.vertices[tri[2]] - p;
      const double la = a.norm(), lb = b.norm(), lc = c.norm();
      w += 2.0 * std::atan2(a.dot(b.cross(c)), la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la);
    }
    w /= 4.0 * M_PI;
    if (std::abs(w) > 1e-6 && std::abs(w - 1.0) > 1e-6) ++bad;
  }
  return bad;
}

/// A 4 x 0.3 x 3 m IFC4 wall (mm; x -2000..2000, y -150..150, z 0..3000) with box openings given
/// as "cx,cy,cz,size_x,size_y,height" in mm (the box spans cz..cz+height, centred in x and y).
std::string wall_model(const std::vector<std::array<double, 6>>& openings) {
  std::string text =
      "ISO-10303-21;\nHEADER;\nFILE_DESCRIPTION(('x'),'2;1');\nFILE_NAME('w','',(''),(''),'','','');\n"
      "FILE_SCHEMA(('IFC4'));\nENDSEC;\nDATA;\n"
      "#1=IFCUNITASSIGNMENT((#2));\n#2=IFCSIUNIT(*,.LENGTHUNIT.,.MILLI.,.METRE.);\n"
      "#5=IFCCARTESIANPOINT((0.,0.,0.));\n#6=IFCDIRECTION((0.,0.,1.));\n"
      "#10=IFCWALL('gw',$,'W',$,$,#11,#13,$,$);\n#11=IFCLOCALPLACEMENT($,#12);\n#12=IFCAXIS2PLACEMENT3D(#5,$,$);\n"
      "#13=IFCPRODUCTDEFINITIONSHAPE($,$,(#20));\n#20=IFCSHAPEREPRESENTATION($,'Body','SweptSolid',(#21));\n"
      "#21=IFCEXTRUDEDAREASOLID(#22,$,#6,3000.);\n#22=IFCRECTANGLEPROFILEDEF(.AREA.,$,$,4000.,300.);\n";
  int id = 100;
  for (const auto& o : openings) {
    auto n = [](double x) { return std::to_string(x); };
    const std::string op = "#" + std::to_string(id), pl = "#" + std::to_string(id + 1), ax = "#" + std::to_string(id + 2),
                      pt = "#" + std::to_string(id + 3), ps = "#" + std::to_string(id + 4), rep = "#" + std::to_string(id + 5),
                      ex = "#" + std::to_string(id + 6), pr = "#" + std::to_string(id + 7), rel = "#" + std::to_string(id + 8);
    text += op + "=IFCOPENINGELEMENT('go" + std::to_string(id) + "',$,'O',$,$," + pl + "," + ps + ",$,$);\n" + pl +
            "=IFCLOCALPLACEMENT($," + ax + ");\n" + ax + "=IFCAXIS2PLACEMENT3D(" + pt + ",$,$);\n" + pt +
            "=IFCCARTESIANPOINT((" + n(o[0]) + "," + n(o[1]) + "," + n(o[2]) + "));\n" + ps +
            "=IFCPRODUCTDEFINITIONSHAPE($,$,(" + rep + "));\n" + rep + "=IFCSHAPEREPRESENTATION($,'Body','SweptSolid',(" +
            ex + "));\n" + ex + "=IFCEXTRUDEDAREASOLID(" + pr + ",$,#6," + n(o[5]) + ");\n" + pr +
            "=IFCRECTANGLEPROFILEDEF(.AREA.,$,$," + n(o[3]) + "," + n(o[4]) + ");\n" + rel + "=IFCRELVOIDSELEMENT('gr" +
            std::to_string(id) + "',$,$,$,#10," + op + ");\n";
    id += 10;
  }
  return text + "ENDSEC;\nEND-ISO-10303-21;\n";
}

void expect_box(const BimMesh& m, double tol) {
  Vector3d lo, hi;
  m.bounds(lo, hi);
  EXPECT_NEAR(lo.x(), 0.5, tol);
  EXPECT_NEAR(hi.x(), 1.5, tol);
  EXPECT_NEAR(lo.y(), -0.5, tol);
  EXPECT_NEAR(hi.y(), 0.5, tol);
  EXPECT_NEAR(lo.z(), 0.0, tol);
  EXPECT_NEAR(hi.z(), 2.0, tol);
}

}  // namespace

TEST(BimMeshTest, BasicShapesGiveTheSameBox) {
  for (const char* name : {"ifc/unit/basic_shape_SweptSolid.ifc", "ifc/unit/basic_shape_Brep.ifc",
                           "ifc/unit/basic_shape_Tessellation.ifc"}) {
    PLUMB_REQUIRE_DATA(path, name);
    SCOPED_TRACE(name);
    const BimMesh m = mesh_of(name);
    ASSERT_EQ(m.elements.size(), 1u);
    EXPECT_EQ(m.elements[0].type, "IfcBuildingElementProxy");
    EXPECT_EQ(m.elements[0].global_id, "1kTvXnbbzCWw8lcMd1dR4o");
    EXPECT_EQ(m.num_triangles(), 12u);
    expect_box(m, 1e-9);
    EXPECT_NEAR(volume_of(m), 2.0, 1e-9);  // closed and outward oriented
    EXPECT_NEAR(area_of(m), 10.0, 1e-9);
    EXPECT_TRUE(m.origin_offset.isZero());
    EXPECT_TRUE(m.warnings.empty()) << m.warnings.front();
  }
}

TEST(BimMeshTest, MappedItemWithNonUniformScale) {
  PLUMB_REQUIRE_DATA(path, "ifc/unit/mapped_shape_transformation.ifc");
  const BimMesh m = mesh_of("ifc/unit/mapped_shape_transformation.ifc");
  // 1 m square scaled by 0.5 in x and y, rotated 45 deg, at x = 1 m; height 2 m (scale 1).
  const double h = 0.25 * std::sqrt(2.0);
  Vector3d lo, hi;
  m.bounds(lo, hi);
  EXPECT_NEAR(lo.x(), 1.0 - h, 1e-9);
  EXPECT_NEAR(hi.x(), 1.0 + h, 1e-9);
  EXPECT_NEAR(lo.y(), -h, 1e-9);
  EXPECT_NEAR(hi.y(), h, 1e-9);
  EXPECT_NEAR(hi.z(), 2.0, 1e-9);
  EXPECT_NEAR(volume_of(m), 0.5, 1e-9);
}

TEST(BimMeshTest, HalfSpaceClippingReducesTheSlabs) {
  PLUMB_REQUIRE_DATA(path, "ifc/unit/ifcopenshell_halfspaces.ifc");
  const BimMesh m = mesh_of("ifc/unit/ifcopenshell_halfspaces.ifc");
  ASSERT_EQ(m.elements.size(), 7u);
  // #97 is the unclipped 10 x 10 x 2 m slab: closed box.
  const int plain = m.find_element(97);
  ASSERT_GE(plain, 0);
  EXPECT_NEAR(volume_of(m, plain), 200.0, 1e-6);
  EXPECT_NEAR(area_of(m, plain), 280.0, 1e-6);
  // #98 is clipped by an unbounded half-space at z = 1.5 m.
  const int clipped = m.find_element(98);
  EXPECT_NEAR(m.elements[static_cast<std::size_t>(clipped)].bbox_max.z(), 1.5, 1e-9);
  EXPECT_NEAR(m.elements[static_cast<std::size_t>(clipped)].bbox_min.z(), 0.0, 1e-9);
  // The bounded half-spaces remove material only inside their polygon: less area, same footprint.
  for (std::uint32_t id : {99u, 100u, 101u, 102u, 103u}) {
    const int e = m.find_element(id);
    ASSERT_GE(e, 0);
    const auto& el = m.elements[static_cast<std::size_t>(e)];
    EXPECT_GT(el.num_triangles, 12u) << id;
    EXPECT_LT(volume_of(m, e), 200.0 - 1.0) << id;
    EXPECT_GT(volume_of(m, e), 50.0) << id;
    EXPECT_NEAR(el.bbox_max.x() - el.bbox_min.x(), 10.0, 1e-9) << id;
  }
  // Every clipped slab stays closed: the cut face is added where the half-space removed material.
  for (std::uint32_t id : {98u, 99u, 100u, 101u, 102u, 103u}) {
    const int e = m.find_element(id);
    EXPECT_EQ(num_fractional_windings(m, e, 200), 0) << id;
    EXPECT_NEAR(volume_from(m, Vector3d(30, -40, 50), e), volume_of(m, e), 1e-6) << id;
  }
}

TEST(BimMeshTest, OpeningLeavesNoSampledPoints) {
  PLUMB_REQUIRE_DATA(path, "ifc/unit/building_element_configuration_wall.ifc");
  const BimMesh m = mesh_of("ifc/unit/building_element_configuration_wall.ifc");
  const int wall = m.find_element(45);
  ASSERT_GE(wall, 0);
  SurfaceSampleSettings s;
  s.spacing = 0.01;
  s.filter.types = {"IfcWallStandardCase"};
  const auto cloud = sample_surface(m, s);
  ASSERT_GT(cloud.size(), 10000u);
  // Opening (from the file): x 1000..2000, y 0..300, z 500..1500 mm.
  std::size_t inside = 0, beside = 0;
  for (const auto& p : cloud.points) {
    EXPECT_EQ(cloud.labels[static_cast<std::size_t>(&p - cloud.points.data())], wall);
    if (p.x() > 1.0 + 1e-4 && p.x() < 2.0 - 1e-4 && p.z() > 0.5 + 1e-4 && p.z() < 1.5 - 1e-4) ++inside;
    if (p.x() < 1.0 && p.z() > 0.5 && p.z() < 1.5) ++beside;
  }
  EXPECT_EQ(inside, 0u);
  EXPECT_GT(beside, 1000u);
  // Wall area: 2 faces of 3 x 2 m minus the 1 x 1 m hole, top/bottom/ends 0.3 m wide, and the four
  // 1 m x 0.3 m reveals of the hole.
  const double expected = 2 * (6.0 - 1.0) + 2 * 3.0 * 0.3 + 2 * 2.0 * 0.3 + 4 * 1.0 * 0.3;
  EXPECT_NEAR(area_of(m, wall), expected, 1e-6);
  // Closed: 3 x 2 x 0.3 m minus the 1 x 1 x 0.3 m hole, whatever the origin of the measurement.
  EXPECT_NEAR(volume_of(m, wall), 1.8 - 0.3, 1e-9);
  EXPECT_NEAR(volume_from(m, Vector3d(10.0, -20.0, 30.0), wall), 1.8 - 0.3, 1e-9);
}

TEST(BimMeshTest, OpeningsLeaveClosedWallsWithReveals) {
  // A door (through, from the floor), a window (through) and a niche 0.1 m deep from the +y face.
  const BimMesh m = build_mesh(parse_ifc(wall_model({{-1000, 0, 0, 1000, 600, 2000},
                                                     {1000, 0, 1000, 800, 600, 1000},
                                                     {1000, 150, 200, 600, 200, 600}})));
  ASSERT_EQ(m.elements.size(), 1u);
  EXPECT_TRUE(m.warnings.empty()) << m.warnings.front();
  // 4 x 0.3 x 3 minus door 1 x 0.3 x 2, window 0.8 x 0.3 x 1, niche 0.6 x 0.1 x 0.6 (m^3).
  const double volume = 3.6 - 0.6 - 0.24 - 0.036;
  EXPECT_NEAR(volume_of(m), volume, 1e-9);
  EXPECT_EQ(num_fractional_windings(m, 0, 300), 0);
  for (const Vector3d& o : {Vector3d(10, 0, 0), Vector3d(-3, 7, -5), Vector3d(0, 0, 100)}) {
    EXPECT_NEAR(volume_from(m, o), volume, 1e-9) << o.transpose();
  }
  // Faces: front 12 - 2 - 0.8, back 12 - 2 - 0.8 - 0.36, top 1.2, bottom 1.2 - 0.3, ends 1.8,
  // door reveals 2 x 0.6 + lintel 0.3, window reveals 2 x 0.3 + 2 x 0.24, niche 0.36 + 4 x 0.06.
  EXPECT_NEAR(area_of(m), 9.2 + 8.84 + 1.2 + 0.9 + 1.8 + 1.5 + 1.08 + 0.6, 1e-9);
  // Rays inside the openings meet the reveals, not the wall's far end.
  EXPECT_NEAR(ray_range(m, Vector3d(-1.0, 0.0, 1.0), Vector3d::UnitX()), 0.5, 1e-9);
  EXPECT_NEAR(ray_range(m, Vector3d(-1.0, 0.1, 1.0), -Vector3d::UnitX()), 0.5, 1e-9);
  EXPECT_NEAR(ray_range(m, Vector3d(-1.0, 0.0, 1.0), Vector3d::UnitZ()), 1.0, 1e-9);
  EXPECT_NEAR(ray_range(m, Vector3d(1.0, 0.0, 1.5), -Vector3d::UnitZ()), 0.5, 1e-9);
  EXPECT_NEAR(ray_range(m, Vector3d(1.0, 0.0, 1.5), Vector3d::UnitX()), 0.4, 1e-9);
  EXPECT_NEAR(ray_range(m, Vector3d(1.0, 1.0, 0.5), -Vector3d::UnitY()), 0.95, 1e-9);
  // Through the door and the window along y: nothing.
  EXPECT_EQ(ray_range(m, Vector3d(-1.0, 1.0, 1.0), -Vector3d::UnitY()), std::numeric_limits<double>::infinity());
  EXPECT_EQ(ray_range(m, Vector3d(1.0, 1.0, 1.5), -Vector3d::UnitY()), std::numeric_limits<double>::infinity());
  // Without subtraction: the plain box.
  BimMeshSettings keep;
  keep.subtract_openings = false;
  const BimMesh plain = build_mesh(parse_ifc(wall_model({{-1000, 0, 0, 1000, 600, 2000}})), keep);
  EXPECT_NEAR(volume_of(plain), 3.6, 1e-9);
  EXPECT_EQ(plain.num_triangles(), 12u);
}

TEST(BimMeshTest, FzkHausWallsAndSlabsAreClosed) {
  // Before reveals and clipping caps were added, 8 walls had fractional winding numbers (holes at
  // doors, windows and the gables).
  PLUMB_REQUIRE_DATA(path, "ifc/buildings/AC20-FZK-Haus.ifc");
  const BimMesh m = mesh_of("ifc/buildings/AC20-FZK-Haus.ifc");
  int checked = 0;
  for (std::size_t e = 0; e < m.elements.size(); ++e) {
    const BimElement& el = m.elements[e];
    if (el.num_triangles == 0 || (el.type.rfind("IfcWall", 0) != 0 && el.type != "IfcSlab")) continue;
    const int ei = static_cast<int>(e);
    const double v = volume_of(m, ei);
    EXPECT_GT(v, 0.0) << el.type << " #" << el.express_id;
    EXPECT_EQ(num_fractional_windings(m, ei, 100), 0) << el.type << " #" << el.express_id;
    // A hole in the surface makes the enclosed "volume" depend on where it is measured from.
    const Vector3d shift = el.bbox_max - el.bbox_min + Vector3d(5.0, 5.0, 5.0);
    EXPECT_NEAR(volume_from(m, el.bbox_min - shift, ei), v, 1e-6 * (1.0 + v)) << el.type << " #" << el.express_id;
    ++checked;
  }
  EXPECT_GT(checked, 10);
}

TEST(BimMeshTest, AcadWallsAllMeshed) {
  PLUMB_REQUIRE_DATA(path, "ifc/unit/acad2010_walls.ifc");
  const BimMesh m = mesh_of("ifc/unit/acad2010_walls.ifc");
  ASSERT_EQ(m.elements.size(), 8u);
  for (const auto& e : m.elements) {
    EXPECT_EQ(e.type, "IfcWallStandardCase");
    EXPECT_GT(e.num_triangles, 0u);
    EXPECT_NEAR(e.bbox_min.z(), 0.0, 1e-9);
    EXPECT_NEAR(e.bbox_max.z(), 3.0, 1e-9);
  }
  EXPECT_GT(volume_of(m), 0.0);
  // A horizontal cut closes into loops: every segment end is another segment's start.
  const FloorPlan plan = slice_floor_plan(m, 1.5);
  ASSERT_FALSE(plan.segment_start.empty());
  for (const auto& e : plan.segment_end) {
    double best = 1e9;
    for (const auto& s : plan.segment_start) best = std::min(best, (s - e).norm());
    EXPECT_LT(best, 1e-9);
  }
}

namespace {
void check_building(const BimMesh& m, const std::map<std::string, std::size_t>& expected, std::size_t storeys) {
  std::map<std::string, std::size_t> with_geometry;
  for (const auto& e : m.elements) {
    if (e.num_triangles > 0) ++with_geometry[e.type];
    if (e.has_body) {
      EXPECT_GT(e.num_triangles, 0u) << e.type << " #" << e.express_id;
    }
  }
  for (const auto& [type, n] : expected) EXPECT_EQ(with_geometry[type], n) << type;
  EXPECT_EQ(m.storeys.size(), storeys);
  for (const auto& e : m.elements) {
    if (expected.count(e.type)) {
      EXPECT_GE(e.storey, 0) << e.type << " #" << e.express_id;
    }
  }
}
}  // namespace

TEST(BimMeshTest, FzkHausElementsAndBounds) {
  PLUMB_REQUIRE_DATA(path, "ifc/buildings/AC20-FZK-Haus.ifc");
  const BimMesh m = mesh_of("ifc/buildings/AC20-FZK-Haus.ifc");
  check_building(m, {{"IfcWallStandardCase", 13}, {"IfcSlab", 4}, {"IfcBeam", 4}, {"IfcDoor", 5}, {"IfcWindow", 11}}, 2);
  Vector3d lo, hi;
  m.bounds(lo, hi);
  EXPECT_NEAR(hi.x() - lo.x(), 13.0, 0.6);  // 12 x 10 m house plus roof overhang
  EXPECT_NEAR(hi.y() - lo.y(), 11.0, 0.6);
  EXPECT_GT(hi.z() - lo.z(), 6.0);
  EXPECT_LT(hi.z() - lo.z(), 8.0);
  EXPECT_TRUE(m.origin_offset.isZero());
}

TEST(BimMeshTest, DuplexElementsAndBounds) {
  PLUMB_REQUIRE_DATA(path, "ifc/buildings/duplex.ifc");
  const BimMesh m = mesh_of("ifc/buildings/duplex.ifc");
  check_building(m, {{"IfcWall", 1}, {"IfcWallStandardCase", 56}, {"IfcSlab", 21}, {"IfcBeam", 8}, {"IfcDoor", 14},
                     {"IfcWindow", 24}}, 4);
  Vector3d lo, hi;
  m.bounds(lo, hi);
  EXPECT_GT(hi.x() - lo.x(), 8.0);
  EXPECT_LT(hi.x() - lo.x(), 25.0);
  EXPECT_GT(hi.y() - lo.y(), 15.0);
  EXPECT_LT(hi.y() - lo.y(), 30.0);
}

TEST(BimMeshTest, FarAwayModelIsRecentred) {
  const BimMesh m = build_mesh(parse_ifc(box_model(5432100.0)));  // 5432.1 m
  EXPECT_DOUBLE_EQ(m.origin_offset.x(), 5400.0);
  EXPECT_DOUBLE_EQ(m.origin_offset.y(), 0.0);
  Vector3d lo, hi;
  m.bounds(lo, hi);
  EXPECT_NEAR(lo.x() + m.origin_offset.x(), 5432.1 - 0.5, 1e-9);
  EXPECT_LT(hi.norm(), 100.0);
}

TEST(BimMeshTest, BrokenReferencesBecomeWarnings) {
  // Dangling representation item.
  const BimMesh a = build_mesh(parse_ifc(box_model(0.0, "", "#21,#99")));
  EXPECT_EQ(a.num_triangles(), 0u);
  ASSERT_FALSE(a.warnings.empty());
  EXPECT_NE(a.warnings[0].find("#99"), std::string::npos) << a.warnings[0];
  // Placement cycle.
  std::string text = box_model(0.0);
  text.replace(text.find("#11=IFCLOCALPLACEMENT($,#12)"), 28, "#11=IFCLOCALPLACEMENT(#11,#12)");
  const BimMesh b = build_mesh(parse_ifc(text));
  EXPECT_EQ(b.num_triangles(), 0u);
  ASSERT_FALSE(b.warnings.empty());
  EXPECT_NE(b.warnings[0].find("cycle"), std::string::npos) << b.warnings[0];
  // Mapped item that maps itself (representation cycle).
  const std::string cyc = box_model(0.0,
      "#30=IFCMAPPEDITEM(#31,#33);\n#31=IFCREPRESENTATIONMAP(#34,#32);\n#32=IFCSHAPEREPRESENTATION($,'Body','x',(#30));\n"
      "#33=IFCCARTESIANTRANSFORMATIONOPERATOR3D($,$,#5,$,$);\n#34=IFCAXIS2PLACEMENT3D(#5,$,$);\n", "#30");
  const BimMesh c = build_mesh(parse_ifc(cyc));
  EXPECT_EQ(c.num_triangles(), 0u);
  EXPECT_FALSE(c.warnings.empty());
  // Unsupported item: a warning naming the entity, the rest still meshed.
  const BimMesh d = build_mesh(parse_ifc(box_model(0.0, "#40=IFCSPHERE(#34,1.);\n#34=IFCAXIS2PLACEMENT3D(#5,$,$);\n", "#21,#40")));
  EXPECT_EQ(d.num_triangles(), 12u);
  ASSERT_EQ(d.warnings.size(), 1u);
  EXPECT_NE(d.warnings[0].find("IFCSPHERE #40"), std::string::npos) << d.warnings[0];
  // Absurd number in a profile.
  std::string absurd = box_model(0.0);
  absurd.replace(absurd.find("1000.,1000."), 11, "1E300,1000.");
  const BimMesh e = build_mesh(parse_ifc(absurd));
  EXPECT_EQ(e.num_triangles(), 0u);
  EXPECT_FALSE(e.warnings.empty());
}

TEST(BimSampleTest, AreaUniformDeterministicAndLabelled) {
  const BimMesh m = build_mesh(parse_ifc(box_model(1000.0)));
  SurfaceSampleSettings s;
  s.spacing = 0.05;
  const auto a = sample_surface(m, s);
  const auto b = sample_surface(m, s);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) ASSERT_EQ(a.points[i], b.points[i]);
  // Area 10 m^2 / 0.0025 = 4000 points (stochastic rounding per triangle: within a few sigma).
  EXPECT_NEAR(static_cast<double>(a.size()), 4000.0, 4 * std::sqrt(12.0));
  a.check_consistent();
  std::size_t top = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const auto& p = a.points[i];
    EXPECT_NEAR(a.normals[i].norm(), 1.0f, 1e-5f);
    EXPECT_EQ(a.labels[i], 0);
    // On the box surface, normal pointing outwards.
    const Eigen::Vector3f c(1.0f, 0.0f, 1.0f);
    EXPECT_GT(a.normals[i].dot(p - c), 0.0f);
    if (std::abs(p.z() - 2.0f) < 1e-6f) ++top;
  }
  EXPECT_NEAR(static_cast<double>(top), 400.0, 4 * std::sqrt(400.0));
  s.seed = 7;
  EXPECT_NE(sample_surface(m, s).points[0], a.points[0]);
  s.filter.types = {"IfcWall"};
  EXPECT_EQ(sample_surface(m, s).size(), 0u);
  s.spacing = 0.0;
  EXPECT_THROW(sample_surface(m, s), plumb::Error);
}

TEST(BimSampleTest, StoreyFilterAndFloorPlan) {
  PLUMB_REQUIRE_DATA(path, "ifc/buildings/AC20-FZK-Haus.ifc");
  const BimMesh m = mesh_of("ifc/buildings/AC20-FZK-Haus.ifc");
  ASSERT_EQ(m.storeys.size(), 2u);
  EXPECT_EQ(find_storey(m, "1"), 1);
  EXPECT_EQ(find_storey(m, m.storeys[0].name), 0);
  EXPECT_THROW(find_storey(m, "no such storey"), plumb::Error);
  SurfaceSampleSettings s;
  s.spacing = 0.1;
  s.filter.storey = 0;
  s.filter.types = {"IfcWallStandardCase"};
  const auto cloud = sample_surface(m, s);
  ASSERT_GT(cloud.size(), 1000u);
  for (std::int32_t l : cloud.labels) {
    const auto& e = m.elements[static_cast<std::size_t>(l)];
    ASSERT_EQ(e.storey, 0);
    ASSERT_EQ(e.type, "IfcWallStandardCase");
  }
  // Ground-floor walls cut at 1 m: the outline spans the 12 x 10 m footprint.
  FloorPlanSettings fs;
  fs.filter = s.filter;
  const FloorPlan plan = slice_floor_plan(m, 1.0, fs);
  ASSERT_FALSE(plan.points.empty());
  Eigen::Vector2f lo = plan.points[0], hi = plan.points[0];
  for (const auto& p : plan.points) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  EXPECT_NEAR(hi.x() - lo.x(), 12.0, 0.1);
  EXPECT_NEAR(hi.y() - lo.y(), 10.0, 0.1);
}
