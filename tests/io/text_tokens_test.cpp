// SPDX-License-Identifier: BSD-3-Clause
// The text readers of io share one private tokenizer (src/io/text_tokens.hpp). These cases, worked
// by hand, pin what each format takes for white space, for a separator and for a field, through
// the public readers: white space is the C locale's six characters, separators run together
// except in the frame dump's CSV files, whose fields keep their empties and are trimmed of blanks
// (' ', '\t', '\r') only.
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "io_test_util.hpp"
#include "plumb/core/error.hpp"
#include "plumb/io/calib_tuples.hpp"
#include "plumb/io/carmen.hpp"
#include "plumb/io/frame_dump.hpp"
#include "plumb/io/pcd.hpp"
#include "plumb/io/ply.hpp"
#include "plumb/io/trajectory.hpp"
#include "plumb/io/wheel_encoders.hpp"

namespace plumb::io {
namespace {

using test::expect_error;

PointCloud pcd(const std::string& text) { return read_pcd_buffer(text.data(), text.size(), "t.pcd"); }
PointCloud ply(const std::string& text) { return read_ply_buffer(text.data(), text.size(), "t.ply"); }

TEST(TextTokensTest, CloudTextSplitsAtEveryKindOfWhiteSpace) {
  // Tabs, '\v' and '\f' separate header words and values like spaces; runs count once.
  const PointCloud a = pcd("FIELDS\tx \v y\fz\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 1\nHEIGHT 1\n"
                           "POINTS 1\nDATA ascii\n \t1\v2\f\f3 \r\n");
  ASSERT_EQ(a.size(), 1u);
  EXPECT_EQ(a.points[0], Vector3f(1.0f, 2.0f, 3.0f));
  // A line of white space only holds no point: the point is on the next line.
  const PointCloud b = pcd("FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1\nPOINTS 1\nDATA ascii\n \t\v\f\n-1 -2 -3\n");
  ASSERT_EQ(b.size(), 1u);
  EXPECT_EQ(b.points[0], Vector3f(-1.0f, -2.0f, -3.0f));
  expect_error([] { pcd("FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1\nPOINTS 1\nDATA ascii\n1 2\t\n"); },
               {"t.pcd:7", "expected 3 values"});
  expect_error([] { pcd("FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1\nPOINTS 1\nDATA ascii\n1 2 3\v4\n"); },
               {"t.pcd:7", "more than the 3 values"});
  const PointCloud c = ply("ply\nformat ascii 1.0\nelement\tvertex 1\nproperty float x\nproperty float y\n"
                           "property\vfloat z\nend_header\n\f5\t6\v7 \r\n");
  ASSERT_EQ(c.size(), 1u);
  EXPECT_EQ(c.points[0], Vector3f(5.0f, 6.0f, 7.0f));
}

TEST(TextTokensTest, TrajectoryFieldsSplitAtRunsOfWhiteSpaceAndCommas) {
  // "1,0 0\t0 ,0 0 0 1": a comma with spaces around it, or two commas, is one separator.
  const Trajectory t =
      parse_tum("  # indented comment\n\v1,0 0\t0 ,0 0 0 1\f\n\n2,,3,,0,0 , 0,0,0,1 \r\n", "t.tum");
  ASSERT_EQ(t.size(), 2u);
  EXPECT_EQ(t.stamps[0], 1.0);
  EXPECT_EQ(t.stamps[1], 2.0);
  EXPECT_EQ(t.poses[1].translation(), Vector3d(3.0, 0.0, 0.0));
  expect_error([] { parse_tum("1 0 0 0 0 0 0 1\n2 0 0 0\v0 0 0\n", "t.tum"); }, {"t.tum:2", "expected 8 fields"});
}

TEST(TextTokensTest, WheelFieldsSplitAtRunsOfCommasSemicolonsAndBlanks) {
  const std::vector<WheelEncoderReading> w =
      parse_wheel_encoders("stamp , left ; right\n0.0 ;, 1\t\t2\r\n\n ,1;;3,,4,\n", "w.csv");
  ASSERT_EQ(w.size(), 2u);
  EXPECT_EQ(w[0].stamp, 0.0);
  EXPECT_EQ(w[0].left, 1.0);
  EXPECT_EQ(w[0].right, 2.0);
  EXPECT_EQ(w[1].stamp, 1.0);
  EXPECT_EQ(w[1].left, 3.0);
  EXPECT_EQ(w[1].right, 4.0);
  // Empty fields do not exist here, so a short line is short, not blank-padded.
  expect_error([] { parse_wheel_encoders("0,1,2\n1,,2\n", "w.csv"); }, {"w.csv:2", "expected 3 fields", "found 2"});
}

TEST(TextTokensTest, FrameDumpCsvKeepsEmptyFieldsAndTrimsBlanksOnly) {
  // Blanks around a field go, blanks inside it stay; the header may be spaced too.
  const FrameDumpIndex index = parse_frame_dump_frames(" index , stamp,file \n 0 ,\t0.5\r, a b.pcd \r\n", "f.csv");
  ASSERT_EQ(index.files.size(), 1u);
  EXPECT_EQ(index.stamps[0], 0.5);
  EXPECT_EQ(index.files[0], "a b.pcd");
  // Every comma is a break: ",," is an empty field, a trailing comma one more field.
  expect_error([] { parse_frame_dump_frames("index,stamp,file\n0,,a.pcd\n", "f.csv"); },
               {"f.csv:2", "stamp is not a finite number: ''"});
  expect_error([] { parse_frame_dump_frames("index,stamp,file\n0,0.5,a.pcd,\n", "f.csv"); },
               {"f.csv:2", "expected 3 comma-separated fields, got 4"});
  expect_error([] { parse_frame_dump_frames("index,stamp,file\n0,0.5,\n", "f.csv"); }, {"f.csv:2", "empty file name"});
  expect_error([] { parse_frame_dump_frames("index,,stamp,file\n", "f.csv"); }, {"f.csv:1", "header"});
  // '\f' and '\v' are not blanks: the field keeps them and is no number.
  expect_error([] { parse_frame_dump_odometry("stamp,x,y,theta\n0,\f1,2,3\n", "o.csv"); },
               {"o.csv:2", "x is not a finite number"});
  expect_error([] { parse_frame_dump_imu("stamp,wx,wy,wz,ax,ay,az\n0,0,0,0,0,0,1\v\n", "i.csv"); },
               {"i.csv:2", "az is not a finite number"});
}

TEST(TextTokensTest, CarmenLinesAreTrimmedAndSplitAtWhiteSpace) {
  const CarmenLog log = parse_carmen("\t ODOM\t1 2\v3 0 0 0 1.0 h 1.0  \r\n \f# note\n  NEFF 1 2\n\n", "c.log");
  ASSERT_EQ(log.odometry.size(), 1u);
  EXPECT_EQ(log.odometry[0].pose.x, 1.0);
  EXPECT_EQ(log.odometry[0].pose.y, 2.0);
  EXPECT_EQ(log.odometry[0].pose.theta, 3.0);
  EXPECT_EQ(log.odometry[0].ipc_timestamp, 1.0);
  EXPECT_EQ(log.num_skipped, 1u);  // NEFF; the indented comment is not a message
}

TEST(TextTokensTest, CalibrationTupleLinesAreTrimmedOfWhiteSpace) {
  const std::vector<CalibrationTuple> t =
      parse_calib_tuples("\v {\"T\":\f1, \"phi_l\": 2,\t\"phi_r\": 3, \"sm\": [4, 5,\v6]} \f\r\n \t\n", "c.tuple");
  ASSERT_EQ(t.size(), 1u);
  EXPECT_EQ(t[0].T, 1.0);
  EXPECT_EQ(t[0].phi_left, 2.0);
  EXPECT_EQ(t[0].phi_right, 3.0);
  EXPECT_EQ(t[0].laser_motion.theta, 6.0);
}

}  // namespace
}  // namespace plumb::io
