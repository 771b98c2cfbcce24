// SPDX-License-Identifier: BSD-3-Clause
// Per-element bounding boxes against web-ifc (the independent reference; golden files made by
// scripts/ifc_golden/webifc_bbox.cjs, see its header).
#include <gtest/gtest.h>

#include <cstdint>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "plumb/bim/mesh.hpp"
#include "test_data.hpp"

namespace {

void compare_with_webifc(const std::string& model_rel, const std::string& golden_name, double tol) {
  const std::string golden_path = plumb::test::source_dir() + "/tests/bim/golden/" + golden_name;
  std::ifstream in(golden_path);
  ASSERT_TRUE(in.good()) << golden_path;
  const nlohmann::json golden = nlohmann::json::parse(in);
  const auto mesh = plumb::bim::build_mesh(plumb::bim::read_ifc(plumb::test::data_path(model_rel)));
  std::size_t compared = 0;
  for (const auto& [id_text, ref] : golden["elements"].items()) {
    const auto id = static_cast<std::uint32_t>(std::stoul(id_text));
    const int e = mesh.find_element(id);
    ASSERT_GE(e, 0) << "#" << id;
    const auto& el = mesh.elements[static_cast<std::size_t>(e)];
    ASSERT_GT(el.num_triangles, 0u) << el.type << " #" << id;
    for (int c = 0; c < 3; ++c) {
      EXPECT_NEAR(el.bbox_min[c] + mesh.origin_offset[c], ref["bbox"][0][c].get<double>(), tol)
          << el.type << " #" << id << " min axis " << c;
      EXPECT_NEAR(el.bbox_max[c] + mesh.origin_offset[c], ref["bbox"][1][c].get<double>(), tol)
          << el.type << " #" << id << " max axis " << c;
    }
    ++compared;
  }
  EXPECT_GT(compared, 30u);
}

/// Per-element surface areas [m^2] against reference values from web-ifc 0.0.78
/// (`node scripts/ifc_golden/webifc_area.cjs MODEL.ifc`), whose boolean difference adds the faces
/// an opening or a clipping half-space cuts into the element (reveals, gable cut faces).
void compare_areas(const std::string& model_rel, const std::vector<std::pair<std::uint32_t, double>>& webifc,
                   double rel_tol) {
  const auto mesh = plumb::bim::build_mesh(plumb::bim::read_ifc(plumb::test::data_path(model_rel)));
  for (const auto& [id, area] : webifc) {
    const int e = mesh.find_element(id);
    ASSERT_GE(e, 0) << "#" << id;
    double a = 0.0;
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
      if (mesh.triangle_element[t] != e) continue;
      const auto& tri = mesh.triangles[t];
      a += 0.5 * (mesh.vertices[tri[1]] - mesh.vertices[tri[0]]).cross(mesh.vertices[tri[2]] - mesh.vertices[tri[0]]).norm();
    }
    EXPECT_NEAR(a, area, rel_tol * area) << "#" << id;
  }
}

}  // namespace

TEST(BimGoldenTest, FzkHausWallAndSlabAreasMatchWebIfc) {
  PLUMB_REQUIRE_DATA(path, "ifc/buildings/AC20-FZK-Haus.ifc");
  // Without reveals the walls with doors and windows were 4-12 % short (e.g. #21966: 46.53 m^2) and
  // the gable walls #67536 / #75347 lacked their cut faces (17.68 m^2). web-ifc's two mirror-image
  // walls #60012 and #67828 differ from each other by 0.002 m^2 and from ours by 0.16 %.
  compare_areas("ifc/buildings/AC20-FZK-Haus.ifc",
                {{15042, 24.300128}, {17040, 29.379229}, {18465, 21.5308}, {18698, 34.977001}, {20598, 20.38},
                 {21966, 51.876827}, {27421, 58.608527}, {31470, 54.731027}, {32407, 63.851028}, {34509, 248.8},
                 {59290, 211.499521}, {59553, 173.66696}, {59753, 173.66696}, {67536, 21.735286}, {75347, 21.735286}},
                1e-5);
  compare_areas("ifc/buildings/AC20-FZK-Haus.ifc", {{60012, 44.728217}, {67828, 44.726008}}, 0.002);
}

TEST(BimGoldenTest, HalfSpaceClippedSlabAreasMatchWebIfc) {
  PLUMB_REQUIRE_DATA(path, "ifc/unit/ifcopenshell_halfspaces.ifc");
  compare_areas("ifc/unit/ifcopenshell_halfspaces.ifc",
                {{97, 280.0}, {98, 240.498756}, {99, 300.124689}, {100, 277.624689}, {101, 320.416763},
                 {102, 320.490557}, {103, 301.946577}},
                1e-5);
}

TEST(BimGoldenTest, FzkHausBoxesMatchWebIfc) {
  PLUMB_REQUIRE_DATA(path, "ifc/buildings/AC20-FZK-Haus.ifc");
  compare_with_webifc("ifc/buildings/AC20-FZK-Haus.ifc", "fzk_haus_webifc_bbox.json", 0.02);
}

TEST(BimGoldenTest, DuplexBoxesMatchWebIfc) {
  PLUMB_REQUIRE_DATA(path, "ifc/buildings/duplex.ifc");
  compare_with_webifc("ifc/buildings/duplex.ifc", "duplex_webifc_bbox.json", 0.02);
}
