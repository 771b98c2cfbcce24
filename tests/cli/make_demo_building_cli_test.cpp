// SPDX-License-Identifier: BSD-3-Clause
// `plumb make-demo-building` as a user runs it: the file it writes is the library's, reads back,
// and the committed example is what the default command writes.
#include <cstdio>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "cli_runner.hpp"
#include "plumb/bim/demo_building.hpp"
#include "plumb/bim/mesh.hpp"
#include "test_data.hpp"

namespace plumb {
namespace {

using test::CliTest;
using test::run_cli;
using Json = nlohmann::json;

TEST_F(CliTest, MakeDemoBuildingWritesTheLibrarysFile) {
  const std::string path = test::temp_path("demo_cli_six_rooms.ifc");
  std::remove(path.c_str());
  const test::RunResult r = run_cli("make-demo-building -o '" + path + "' --rooms 6 --seed 3 --storeys 2 --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  bim::DemoBuildingSettings s;
  s.num_rooms = 6;
  s.seed = 3;
  s.num_storeys = 2;
  s.file_name = "test_tmp_demo_cli_six_rooms.ifc";
  EXPECT_TRUE(test::read_text(path) == bim::make_demo_building(s).ifc);
  const Json j = Json::parse(r.out);
  EXPECT_EQ(j.at("storeys").get<int>(), 2);
  EXPECT_EQ(j.at("walls").get<int>(), 2 * (6 + 4));
  EXPECT_EQ(j.at("doors").get<int>(), 2 * 6 + 1);
  EXPECT_EQ(j.at("windows").get<int>(), 2 * (6 + 2) - 1);
  EXPECT_EQ(j.at("slabs").get<int>(), 3);
  EXPECT_EQ(j.at("spaces").size(), 2u * 7u);
  EXPECT_NEAR(j.at("gross_floor_area").get<double>(), 2 * 30.0 * 15.0, 1e-9);
  const bim::IfcModel model = bim::read_ifc(path);
  EXPECT_TRUE(model.warnings.empty());
  const bim::BimMesh mesh = bim::build_mesh(model);
  EXPECT_TRUE(mesh.warnings.empty());
  EXPECT_EQ(mesh.storeys.size(), 2u);
}

TEST_F(CliTest, MakeDemoBuildingDefaultIsTheCommittedExample) {
  const std::string dir = test::temp_path("demo_cli_default");
  ASSERT_EQ(std::system(("mkdir -p '" + dir + "'").c_str()), 0);
  const std::string path = dir + "/demo_office.ifc";
  const test::RunResult r = run_cli("make-demo-building -o '" + path + "'");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("9 doors"), std::string::npos) << r.out;
  EXPECT_TRUE(test::read_text(path) == test::read_text(test::source_dir() + "/examples/data/demo_office.ifc"));
}

TEST_F(CliTest, MakeDemoBuildingRejectsRoomsThatDoNotFit) {
  const std::string path = test::temp_path("demo_cli_too_many.ifc");
  std::remove(path.c_str());
  const test::RunResult r = run_cli("make-demo-building -o '" + path + "' --rooms 40");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("rooms do not fit"), std::string::npos) << r.err;
  EXPECT_FALSE(test::file_exists(path));
}

TEST_F(CliTest, MakeDemoBuildingNeedsAnOutput) {
  const test::RunResult r = run_cli("make-demo-building --rooms 4");
  EXPECT_GE(r.exit_code, 100);
  EXPECT_NE(r.err.find("output"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace plumb
