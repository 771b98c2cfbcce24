// SPDX-License-Identifier: BSD-3-Clause
// Per-element bounding boxes against web-ifc (the independent reference; golden files made by
// scripts/ifc_golden/webifc_bbox.cjs, see its header).
#include <gtest/gtest.h>

#include <fstream>
#include <string>

#include <nlohmann/json.hpp>

#include "plumb/bim/mesh.hpp"
#include "test_data.hpp"

namespace {

void compare_with_webifc(const std::string& model_rel, const std::string& golden_name, double tol) {
  const std::string golden_path = std::string(PLUMB_SOURCE_DIR) + "/tests/bim/golden/" + golden_name;
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

}  // namespace

TEST(BimGoldenTest, FzkHausBoxesMatchWebIfc) {
  PLUMB_REQUIRE_DATA(path, "ifc/buildings/AC20-FZK-Haus.ifc");
  compare_with_webifc("ifc/buildings/AC20-FZK-Haus.ifc", "fzk_haus_webifc_bbox.json", 0.02);
}

TEST(BimGoldenTest, DuplexBoxesMatchWebIfc) {
  PLUMB_REQUIRE_DATA(path, "ifc/buildings/duplex.ifc");
  compare_with_webifc("ifc/buildings/duplex.ifc", "duplex_webifc_bbox.json", 0.02);
}
