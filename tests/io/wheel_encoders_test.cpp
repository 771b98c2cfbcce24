// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/io/wheel_encoders.hpp"

#include <cmath>
#include <fstream>

#include <gtest/gtest.h>

#include "io_test_util.hpp"
#include "test_data.hpp"

namespace {

using plumb::io::parse_wheel_encoders;
using plumb::test::expect_error;

TEST(WheelEncodersTest, ParsesHeaderCommentsSeparatorsAndCrlf) {
  const std::string text =
      "# robot 7, run 3\r\n"
      "stamp,left,right\r\n"
      "0.0,0,0\r\n"
      "\r\n"
      "0.1 ; 0.25 ; -0.5\n"
      "0.2\t0.5\t-1.0\textra\n";
  const auto r = parse_wheel_encoders(text, "w.csv");
  ASSERT_EQ(r.size(), 3u);
  EXPECT_DOUBLE_EQ(r[1].stamp, 0.1);
  EXPECT_DOUBLE_EQ(r[1].left, 0.25);
  EXPECT_DOUBLE_EQ(r[1].right, -0.5);
  EXPECT_DOUBLE_EQ(r[2].right, -1.0);
}

TEST(WheelEncodersTest, TicksBecomeAngles) {
  plumb::io::WheelEncoderReadSettings s;
  s.ticks_per_revolution = 4096;
  const auto r = parse_wheel_encoders("1.0,4096,-2048\n2.0,8192,0\n", "w.csv", s);
  ASSERT_EQ(r.size(), 2u);
  EXPECT_NEAR(r[0].left, 2.0 * M_PI, 1e-12);
  EXPECT_NEAR(r[0].right, -M_PI, 1e-12);
  EXPECT_NEAR(r[1].left, 4.0 * M_PI, 1e-12);
}

TEST(WheelEncodersTest, WriteReadIsLossless) {
  std::vector<plumb::WheelEncoderReading> in;
  for (int i = 0; i < 50; ++i) {
    in.push_back({1e9 + 0.0123456789 * i, std::sin(0.1 * i) * 1e3, -std::exp(0.01 * i) / 3.0});
  }
  const std::string path = plumb::test::temp_path("wheels_roundtrip.csv");
  plumb::io::write_wheel_encoders(in, path);
  const auto out = plumb::io::read_wheel_encoders(path);
  ASSERT_EQ(out.size(), in.size());
  for (std::size_t i = 0; i < in.size(); ++i) {
    EXPECT_EQ(out[i].stamp, in[i].stamp);
    EXPECT_EQ(out[i].left, in[i].left);
    EXPECT_EQ(out[i].right, in[i].right);
  }
}

TEST(WheelEncodersTest, MalformedInputNamesFileAndLine) {
  expect_error([] { parse_wheel_encoders("", "w.csv"); }, {"w.csv", "no wheel encoder reading"});
  expect_error([] { parse_wheel_encoders("# only a comment\nstamp,left,right\n", "w.csv"); },
               {"w.csv", "no wheel encoder reading"});
  expect_error([] { parse_wheel_encoders("0,1,2\n1,2\n", "w.csv"); }, {"w.csv:2", "3 fields"});
  expect_error([] { parse_wheel_encoders("0,1,2\n1,x,2\n", "w.csv"); }, {"w.csv:2", "numbers"});
  expect_error([] { parse_wheel_encoders("0,1,2\n1,nan,2\n", "w.csv"); }, {"w.csv:2", "non-finite"});
  expect_error([] { parse_wheel_encoders("0,1,2\n0,2,3\n", "w.csv"); }, {"w.csv:2", "does not increase"});
  expect_error([] { parse_wheel_encoders("stamp,left,right\nstamp,left,right\n", "w.csv"); }, {"w.csv:2"});
  plumb::io::WheelEncoderReadSettings s;
  s.ticks_per_revolution = -1;
  expect_error([&] { parse_wheel_encoders("0,1,2\n", "w.csv", s); }, {"w.csv", "ticks_per_revolution"});
  expect_error([] { plumb::io::read_wheel_encoders("/nonexistent/w.csv"); }, {"/nonexistent/w.csv", "no such file"});
}

}  // namespace
