// SPDX-License-Identifier: BSD-3-Clause
// `plumb calibrate`: runs the built binary (${PLUMB_BINARY_DIR}/examples/plumb) as a user would;

#include <sys/wait.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <limits>
#include <string>

#include <gtest/gtest.h>

#include "cli_runner.hpp"
#include "test_data.hpp"

namespace {

using plumb::test::read_text;
using plumb::test::RunResult;

RunResult run(const std::string& args) { return plumb::test::run_cli(args); }

double json_number(const std::string& text, const std::string& key) {
  return plumb::test::json_number(text, "", key);
}

using CalibrateCliTest = plumb::test::CliTest;

TEST_F(CalibrateCliTest, JsonMatchesCensiResult) {
  PLUMB_REQUIRE_DATA(tuples, "laser2d/calibration_censi/l90_1.tuple");
  PLUMB_REQUIRE_DATA(reference, "laser2d/calibration_censi/l90_1_results.json");
  const RunResult r = run("calibrate '" + tuples + "' --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out.find('\n'), r.out.size() - 1) << "one JSON line expected: " << r.out;
  const std::string ref = read_text(reference);
  // Censi prints 6 significant digits; diameters in metres in both.
  for (const char* key : {"axle", "l_diam", "r_diam", "l_x", "l_y", "l_theta"}) {
    const double ours = json_number(r.out, key), his = json_number(ref, key);
    ASSERT_TRUE(std::isfinite(ours)) << key << " missing in " << r.out;
    EXPECT_NEAR(ours, his, 1e-5 * std::abs(his)) << key;
  }
  EXPECT_NE(r.out.find("\"covariance\":[["), std::string::npos);
}

TEST_F(CalibrateCliTest, TableNamesTheParameters) {
  PLUMB_REQUIRE_DATA(tuples, "laser2d/calibration_censi/l90_0.tuple");
  const RunResult r = run("calibrate '" + tuples + "'");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("axle [m]"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("0.0878146"), std::string::npos) << r.out;  // Censi's axle for l90_0
}

TEST_F(CalibrateCliTest, MalformedFileFailsWithFileAndLine) {
  const std::string path = plumb::test::temp_path("calib_cli_bad.tuple");
  {
    std::ofstream out(path);
    out << "{ \"T\": 1, \"phi_l\": 0, \"phi_r\": 0, \"sm\": [0, 0, 0] }\n";
    out << "{ \"T\": 1, \"phi_l\": 0, \"phi_r\": 0, \"sm\": [0, 0] }\n";
  }
  const RunResult r = run("calibrate '" + path + "' --json");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_TRUE(r.out.empty()) << r.out;
  EXPECT_NE(r.err.find(path + ":2:"), std::string::npos) << r.err;
  std::remove(path.c_str());
}

TEST_F(CalibrateCliTest, DegenerateDataFailsWithStatus) {
  const std::string path = plumb::test::temp_path("calib_cli_straight.tuple");
  {
    std::ofstream out(path);
    for (int i = 0; i < 20; ++i)
      out << "{ \"T\": 1, \"phi_l\": 0.5, \"phi_r\": 0.5, \"sm\": [0.01, 0, 0] }\n";
  }
  const RunResult r = run("calibrate '" + path + "'");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("degenerate"), std::string::npos) << r.err;
  std::remove(path.c_str());
}

TEST_F(CalibrateCliTest, MissingFileFails) {
  const RunResult r = run("calibrate /nonexistent/x.tuple");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("/nonexistent/x.tuple"), std::string::npos) << r.err;
}

}  // namespace
