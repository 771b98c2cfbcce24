// SPDX-License-Identifier: BSD-3-Clause
// `plumb ifcinfo` and `plumb ifc2cloud` on the real IFC files, as a user runs them.
#include <fstream>
#include <map>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "cli_runner.hpp"
#include "plumb/io/pcd.hpp"
#include "test_data.hpp"

namespace plumb {
namespace {

using test::CliTest;
using test::run_cli;
using Json = nlohmann::json;

TEST_F(CliTest, IfcinfoReportsTheExactBoxOfTheSweptSolid) {
  PLUMB_REQUIRE_DATA(model, "ifc/unit/basic_shape_SweptSolid.ifc");
  const test::RunResult r = run_cli("ifcinfo '" + model + "' --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const Json j = Json::parse(r.out);
  EXPECT_EQ(j.at("schema"), "IFC4");
  EXPECT_DOUBLE_EQ(j.at("length_to_m").get<double>(), 0.001);
  const Json& bbox = j.at("bbox");  // SOURCES.md: x in [500,1500], y in [-500,500], z in [0,2000] mm
  EXPECT_NEAR(bbox[0][0].get<double>(), 0.5, 1e-9);
  EXPECT_NEAR(bbox[0][1].get<double>(), -0.5, 1e-9);
  EXPECT_NEAR(bbox[0][2].get<double>(), 0.0, 1e-9);
  EXPECT_NEAR(bbox[1][0].get<double>(), 1.5, 1e-9);
  EXPECT_NEAR(bbox[1][1].get<double>(), 0.5, 1e-9);
  EXPECT_NEAR(bbox[1][2].get<double>(), 2.0, 1e-9);
  EXPECT_EQ(j.at("triangles").get<int>(), 12);
  EXPECT_EQ(j.at("elements").at("IfcBuildingElementProxy").at("with_geometry").get<int>(), 1);
}

TEST_F(CliTest, IfcinfoCountsFzkHausElements) {
  PLUMB_REQUIRE_DATA(model, "ifc/buildings/AC20-FZK-Haus.ifc");
  const test::RunResult r = run_cli("ifcinfo '" + model + "' --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const Json j = Json::parse(r.out);
  const Json& e = j.at("elements");
  // SOURCES.md: 13 IfcWallStandardCase, 4 IfcSlab, 5 doors, 11 windows, 2 storeys.
  auto total = [&](const char* type) {
    return e.at(type).at("with_geometry").get<int>() + e.at(type).at("without_geometry").get<int>();
  };
  EXPECT_EQ(total("IfcWallStandardCase"), 13);
  EXPECT_EQ(total("IfcSlab"), 4);
  EXPECT_EQ(total("IfcDoor"), 5);
  EXPECT_EQ(total("IfcWindow"), 11);
  EXPECT_EQ(e.at("IfcWallStandardCase").at("with_geometry").get<int>(), 13);
  // The rooms are meshed too (a floor plan may need them): all 7 IfcSpace of the file.
  EXPECT_EQ(e.at("IfcSpace").at("with_geometry").get<int>(), 7);
  EXPECT_EQ(j.at("storeys").size(), 2u);
  EXPECT_EQ(j.at("storeys")[0].at("floor_source"), "surfaces");
}

TEST_F(CliTest, Ifc2cloudWritesOnlyTheRequestedTypeInsideItsElements) {
  PLUMB_REQUIRE_DATA(model, "ifc/buildings/AC20-FZK-Haus.ifc");
  const std::string cloud_path = test::temp_path("fzk_walls.pcd");
  const std::string elements_path = test::temp_path("fzk_walls_elements.json");
  const test::RunResult r = run_cli("ifc2cloud '" + model + "' -o '" + cloud_path +
                                    "' --spacing 0.1 --types IfcWallStandardCase --elements-out '" +
                                    elements_path + "' --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const Json summary = Json::parse(r.out);
  const PointCloud cloud = io::read_pcd(cloud_path);
  EXPECT_EQ(cloud.size(), summary.at("points").get<std::size_t>());
  ASSERT_TRUE(cloud.has_labels());
  ASSERT_TRUE(cloud.has_normals());

  std::ifstream in(elements_path);
  ASSERT_TRUE(in.good());
  const Json elements = Json::parse(in);
  ASSERT_EQ(elements.size(), 13u);
  std::map<int, Json> by_label;
  for (const Json& el : elements) {
    EXPECT_EQ(el.at("type"), "IfcWallStandardCase");
    by_label[el.at("label").get<int>()] = el;
  }
  // Every point carries the label of a listed wall and lies in that wall's bounding box.
  std::size_t outside = 0;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const auto it = by_label.find(cloud.labels[i]);
    ASSERT_NE(it, by_label.end()) << "label " << cloud.labels[i];
    const Json& b = it->second.at("bbox");
    for (int a = 0; a < 3; ++a) {
      const double v = cloud.points[i][a];
      if (v < b[0][a].get<double>() - 1e-3 || v > b[1][a].get<double>() + 1e-3) ++outside;
    }
  }
  EXPECT_EQ(outside, 0u);
  // Area-uniform at 0.1 m spacing: roughly one point per 0.01 m^2 of wall surface, so thousands.
  EXPECT_GT(cloud.size(), 5000u);
}

TEST_F(CliTest, IfcErrorsExitNonZeroWithTheFileName) {
  const test::RunResult missing = run_cli("ifcinfo /nonexistent/model.ifc");
  EXPECT_NE(missing.exit_code, 0);
  EXPECT_NE(missing.err.find("/nonexistent/model.ifc"), std::string::npos) << missing.err;

  PLUMB_REQUIRE_DATA(model, "ifc/unit/basic_shape_SweptSolid.ifc");
  const std::string text = test::read_text(model);
  const std::string truncated = test::temp_path("truncated.ifc");
  std::ofstream(truncated, std::ios::binary) << text.substr(0, text.size() / 2);
  const test::RunResult r = run_cli("ifcinfo '" + truncated + "'");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("truncated.ifc"), std::string::npos) << r.err;
  EXPECT_EQ(r.out.find("schema"), std::string::npos);
}

TEST_F(CliTest, Scan2dWritesOnePosePerScan) {
  PLUMB_REQUIRE_DATA(log, "laser2d/carmen_corrected/intel-corrected.log.gz");
  const std::string out = test::temp_path("intel_scan2d.tum");
  const test::RunResult r = run_cli("scan2d '" + log + "' -o '" + out + "' --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const Json j = Json::parse(r.out);
  // SOURCES.md: 910 FLASER messages, 4 of them stamped earlier than the one before: dropped.
  EXPECT_EQ(j.at("dropped_scans").get<int>(), 4);
  EXPECT_EQ(j.at("scans").get<int>(), 906);
  EXPECT_LT(j.at("fallbacks").get<int>(), 50);
  std::ifstream in(out);
  std::string line;
  int poses = 0;
  while (std::getline(in, line)) {
    if (!line.empty() && line[0] != '#') ++poses;
  }
  EXPECT_EQ(poses, 906);
  const test::RunResult bad = run_cli("scan2d /nonexistent/log.gz -o '" + out + "'");
  EXPECT_NE(bad.exit_code, 0);
  EXPECT_NE(bad.err.find("/nonexistent/log.gz"), std::string::npos) << bad.err;
}

}  // namespace
}  // namespace plumb
