// SPDX-License-Identifier: BSD-3-Clause
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <string>

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
    EXPECT_LT(area_of(m, e), 280.0 - 1.0) << id;
    EXPECT_GT(area_of(m, e), 100.0) << id;
    EXPECT_NEAR(el.bbox_max.x() - el.bbox_min.x(), 10.0, 1e-9) << id;
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
  // Wall area: 2 faces of 3 x 2 m minus the 1 x 1 m hole, top/bottom/ends 0.3 m wide, reveals are not generated.
  const double expected = 2 * (6.0 - 1.0) + 2 * 3.0 * 0.3 + 2 * 2.0 * 0.3 - 2 * 1.0 * 0.3 * 0.0;
  EXPECT_NEAR(area_of(m, wall), expected, 1e-6);
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
