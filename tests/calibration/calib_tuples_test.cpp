// SPDX-License-Identifier: BSD-3-Clause
// Reader/writer of Censi's calibration tuple files (JSON lines).

#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "plumb/core/error.hpp"
#include "plumb/io/calib_tuples.hpp"
#include "test_data.hpp"

namespace {

using plumb::CalibrationTuple;
using plumb::io::parse_calib_tuples;

/// The plumb::Error message of parsing `text`, or "" when it parses.
std::string parse_error(const std::string& text) {
  try {
    parse_calib_tuples(text, "t.tuple");
  } catch (const plumb::Error& e) {
    return e.what();
  }
  return "";
}

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

TEST(CalibTuplesTest, ParsesCensiLine) {
  const auto t = parse_calib_tuples(
      "{ \"T\": 7.943960e-01, \"phi_l\": 1.401765e-01, \"phi_r\": -1.373157e-01, \"sm\": [ 1.092608e-03, "
      "-5.089714e-04, -2.748851e-02 ] }\n",
      "x");
  ASSERT_EQ(t.size(), 1u);
  EXPECT_DOUBLE_EQ(t[0].T, 0.794396);
  EXPECT_DOUBLE_EQ(t[0].phi_left, 0.1401765);
  EXPECT_DOUBLE_EQ(t[0].phi_right, -0.1373157);
  EXPECT_DOUBLE_EQ(t[0].laser_motion.x, 1.092608e-03);
  EXPECT_DOUBLE_EQ(t[0].laser_motion.y, -5.089714e-04);
  EXPECT_DOUBLE_EQ(t[0].laser_motion.theta, -2.748851e-02);
}

TEST(CalibTuplesTest, AcceptsKeyOrderExtraKeysCommentsCrlfAndSharedLines) {
  const std::string text =
      "# a comment\r\n"
      "\r\n"
      "{\"sm\":[1,2,3],\"phi_r\":2,\"note\":\"x, y]\",\"flags\":[true,null,\"a\"],\"phi_l\":1,\"T\":0.5,"
      "\"ok\":false}\r\n"
      "{ \"T\": 1, \"phi_l\": 0, \"phi_r\": 0, \"sm\": [0, 0, 0] }{ \"T\": 2, \"phi_l\": 0, \"phi_r\": 0, "
      "\"sm\": [0, 0, 0.5] }";
  const auto t = parse_calib_tuples(text, "x");
  ASSERT_EQ(t.size(), 3u);
  EXPECT_EQ(t[0].T, 0.5);
  EXPECT_EQ(t[0].phi_left, 1.0);
  EXPECT_EQ(t[0].phi_right, 2.0);
  EXPECT_EQ(t[0].laser_motion.theta, 3.0);
  EXPECT_EQ(t[2].T, 2.0);
  EXPECT_EQ(t[2].laser_motion.theta, 0.5);
}

TEST(CalibTuplesTest, MalformedLinesThrowWithFileAndLine) {
  const std::string good = "{ \"T\": 1, \"phi_l\": 0, \"phi_r\": 0, \"sm\": [0, 0, 0] }\n";
  struct Case {
    std::string line;
    std::string message;
  };
  const std::vector<Case> cases = {
      {"{ \"T\": 1, \"phi_l\": 0, \"phi_r\": 0 }", "missing key \"sm\""},
      {"{ \"T\": 1, \"phi_l\": 0, \"sm\": [0, 0, 0] }", "missing key \"phi_r\""},
      {"{ \"T\": 1, \"phi_l\": 0, \"phi_r\": 0, \"sm\": [0, 0] }", "3 numbers"},
      {"{ \"T\": 1, \"phi_l\": 0, \"phi_r\": 0, \"sm\": [0, 0, 0, 1] }", "3 numbers"},
      {"{ \"T\": 0, \"phi_l\": 0, \"phi_r\": 0, \"sm\": [0, 0, 0] }", "must be > 0"},
      {"{ \"T\": -1, \"phi_l\": 0, \"phi_r\": 0, \"sm\": [0, 0, 0] }", "must be > 0"},
      {"{ \"T\": 1, \"phi_l\": nan, \"phi_r\": 0, \"sm\": [0, 0, 0] }", "number"},
      {"{ \"T\": 1, \"phi_l\": 1e999, \"phi_r\": 0, \"sm\": [0, 0, 0] }", "finite"},
      {"{ \"T\": 1, \"phi_l\": 0x1, \"phi_r\": 0, \"sm\": [0, 0, 0] }", "expected ','"},
      {"{ \"T\": 1, \"T\": 2, \"phi_l\": 0, \"phi_r\": 0, \"sm\": [0, 0, 0] }", "appears twice"},
      {"{ \"T\": 1, \"phi_l\": 0, \"phi_r\": 0, \"sm\": [0, 0, 0] ", "expected ',' or '}'"},
      {"{ \"T\": 1, \"phi_l\": 0, \"phi_r\": 0, \"sm\": [0, 0, 0] } trailing", "expected '{'"},
      {"1 2 3 4", "expected '{'"},
      {"{ \"T\": 1, \"phi_l\": 0, \"phi_r\": 0, \"sm\": [0, 0, 0], \"x\": {\"a\": 1} }", "nested"},
      {"{ \"T: 1 }", "unterminated string"},
      {"{}", "empty object"},
  };
  for (const Case& c : cases) {
    const std::string msg = parse_error(good + good + c.line + "\n" + good);
    EXPECT_TRUE(contains(msg, "t.tuple:3:")) << c.line << " -> " << msg;
    EXPECT_TRUE(contains(msg, c.message)) << c.line << " -> " << msg;
  }
}

TEST(CalibTuplesTest, EmptyOrMissingFileThrows) {
  EXPECT_TRUE(contains(parse_error(""), "no calibration tuples"));
  EXPECT_TRUE(contains(parse_error("# only a comment\n\n"), "no calibration tuples"));
  EXPECT_THROW(plumb::io::read_calib_tuples("/nonexistent/dir/x.tuple"), plumb::Error);
}

TEST(CalibTuplesTest, WriteReadRoundTripIsLossless) {
  std::vector<CalibrationTuple> tuples;
  for (int i = 0; i < 50; ++i) {
    CalibrationTuple t;
    t.T = 0.1 + i / 7.0;
    t.phi_left = std::sin(i * 1.3) / 3.0;
    t.phi_right = -std::cos(i * 0.7) * 1e-7;
    t.laser_motion = plumb::Pose2{1.0 / (i + 3.0), -0.1 / 3.0 * i, 3.14159 * std::sin(i)};
    tuples.push_back(t);
  }
  const std::string path = plumb::test::temp_path("calib_roundtrip.tuple");
  plumb::io::write_calib_tuples(tuples, path);
  const auto back = plumb::io::read_calib_tuples(path);
  std::remove(path.c_str());
  ASSERT_EQ(back.size(), tuples.size());
  for (std::size_t i = 0; i < tuples.size(); ++i) {
    EXPECT_EQ(back[i].T, tuples[i].T);
    EXPECT_EQ(back[i].phi_left, tuples[i].phi_left);
    EXPECT_EQ(back[i].phi_right, tuples[i].phi_right);
    EXPECT_EQ(back[i].laser_motion.x, tuples[i].laser_motion.x);
    EXPECT_EQ(back[i].laser_motion.y, tuples[i].laser_motion.y);
    EXPECT_EQ(back[i].laser_motion.theta, tuples[i].laser_motion.theta);
  }
  EXPECT_THROW(plumb::io::write_calib_tuples(tuples, "/nonexistent/dir/x.tuple"), plumb::Error);
}

TEST(CalibTuplesTest, ReadsCensiFiles) {
  // l90.tuple concatenates the three runs l90_0..2 (two joins without a newline).
  PLUMB_REQUIRE_DATA(all, "laser2d/calibration_censi/l90.tuple");
  PLUMB_REQUIRE_DATA(part0, "laser2d/calibration_censi/l90_0.tuple");
  PLUMB_REQUIRE_DATA(part1, "laser2d/calibration_censi/l90_1.tuple");
  PLUMB_REQUIRE_DATA(part2, "laser2d/calibration_censi/l90_2.tuple");
  const auto t = plumb::io::read_calib_tuples(all);
  const auto t0 = plumb::io::read_calib_tuples(part0);
  const auto t1 = plumb::io::read_calib_tuples(part1);
  const auto t2 = plumb::io::read_calib_tuples(part2);
  EXPECT_EQ(t0.size(), 1099u);
  EXPECT_EQ(t1.size(), 1098u);
  EXPECT_EQ(t2.size(), 1098u);
  EXPECT_EQ(t.size(), t0.size() + t1.size() + t2.size());
  // first line of l90.tuple
  EXPECT_DOUBLE_EQ(t.front().T, 7.943960e-01);
  EXPECT_DOUBLE_EQ(t.front().laser_motion.theta, -2.748851e-02);
}

}  // namespace
