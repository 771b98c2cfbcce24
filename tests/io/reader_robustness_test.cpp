// SPDX-License-Identifier: BSD-3-Clause
// Inputs that the reader fuzzers (fuzz/*_fuzz.cpp) and their review turned up, and the in-memory
// entry points those fuzzers drive: every bad input must give plumb::Error naming the input (and
// the line, where the format has lines), never a crash, a huge allocation or a hang.

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <cstdint>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "io_test_util.hpp"
#include "test_data.hpp"
#include "plumb/core/error.hpp"
#include "plumb/io/calib_tuples.hpp"
#include "plumb/io/carmen.hpp"
#include "plumb/io/cloud_io.hpp"
#include "plumb/io/frame_dump.hpp"
#include "plumb/io/kitti_bin.hpp"
#include "plumb/io/pcd.hpp"
#include "plumb/io/ply.hpp"
#include "plumb/io/trajectory.hpp"
#include "plumb/io/wheel_encoders.hpp"

namespace plumb::io {
namespace {

using test::expect_error;

std::uint32_t crc32(const std::string& data) {
  std::uint32_t crc = 0xffffffffu;
  for (unsigned char byte : data) {
    crc ^= byte;
    for (int k = 0; k < 8; ++k) crc = (crc >> 1) ^ (0xedb88320u & (0u - (crc & 1u)));
  }
  return ~crc;
}

void put_le32(std::string& out, std::uint32_t v) {
  for (int k = 0; k < 4; ++k) out += static_cast<char>((v >> (8 * k)) & 0xffu);
}

/// One gzip member holding `text` in stored (uncompressed) deflate blocks (RFC 1951/1952).
std::string gzip_stored(const std::string& text) {
  std::string out("\x1f\x8b\x08\x00\x00\x00\x00\x00\x00\xff", 10);
  std::size_t pos = 0;
  do {
    const std::size_t n = std::min<std::size_t>(text.size() - pos, 65535);
    const bool last = pos + n == text.size();
    out += static_cast<char>(last ? 1 : 0);  // BFINAL, BTYPE 00 (stored)
    out += static_cast<char>(n & 0xffu);
    out += static_cast<char>(n >> 8);
    out += static_cast<char>(~n & 0xffu);
    out += static_cast<char>((~n >> 8) & 0xffu);
    out.append(text, pos, n);
    pos += n;
  } while (pos < text.size());
  put_le32(out, crc32(text));
  put_le32(out, static_cast<std::uint32_t>(text.size()));
  return out;
}

CarmenLog read_carmen_bytes(const std::string& bytes, const std::string& name) {
  return read_carmen_buffer(bytes.data(), bytes.size(), name);
}

const char* const kSmallLog =
    "PARAM robot_frontlaser_offset 0.0 nohost 0\n"
    "ODOM 0.1 0.2 0.03 0.5 0.01 0 1.0 host 1.0\n"
    "FLASER 3 1.5 2.25 3 0.1 0.2 0.03 0.1 0.2 0.03 1.05 host 1.05\n"
    "ODOM 0.15 0.2 0.04 0.5 0.01 0 1.1 host 1.1\n";

// ---- CARMEN ----------------------------------------------------------------------------------------

// A line of millions of fields used to be split completely before any count was checked: 16 bytes
// per field, so a 1 MB gzip of one such line asked for 8 GB.
TEST(ReaderRobustnessTest, CarmenLineWithMoreFieldsThanAnyMessageIsAnError) {
  std::string text = "ODOM 0 0 0 0 0 0 1 h 1\nFLASER 5";
  for (std::size_t i = 0; i < 2000030; ++i) text += " 0";
  text += '\n';
  expect_error([&] { parse_carmen(text, "big.log"); }, {"big.log:2", "FLASER", "more than 2000024 fields"});
  expect_error([&] { read_carmen_bytes(gzip_stored(text), "big.log.gz"); }, {"big.log.gz:2", "more than"});
}

// The largest legal message: a FLASER of 1,000,000 beams (the most read_carmen accepts) is read.
TEST(ReaderRobustnessTest, CarmenLargestLegalScanIsRead) {
  std::string text = "ODOM 0 0 0 0 0 0 1 h 1\nFLASER 1000000";
  for (std::size_t i = 0; i < 1000000; ++i) text += i % 2 == 0 ? " 1.5" : " 2.25";
  text += " 0 0 0 0 0 0 1.05 h 1.05\n";
  const CarmenLog log = parse_carmen(text, "dense.log");
  ASSERT_EQ(log.lasers.size(), 1u);
  ASSERT_EQ(log.lasers[0].scan.ranges.size(), 1000000u);
  EXPECT_EQ(log.lasers[0].scan.ranges[999999], 2.25);
  std::string over = "FLASER 1000001";
  expect_error([&] { parse_carmen(over + " 0 0 0 0 0 0 1 h 1\n", "over.log"); }, {"over.log:1"});
}

// A gzip log is inflated before it is parsed; past max_inflated_bytes of text the reader stops
// and names the input, so a small hostile file (deflate reaches ~1000:1) cannot take gigabytes.
TEST(ReaderRobustnessTest, CarmenGzipInflatingPastTheCapIsAnError) {
  std::string text;
  for (int k = 0; k < 200; ++k) text += kSmallLog;
  const std::string gz = gzip_stored(text);
  CarmenReadSettings settings;
  settings.max_inflated_bytes = text.size();
  EXPECT_EQ(read_carmen_buffer(gz.data(), gz.size(), "fits.log.gz", settings).lasers.size(), 200u);
  settings.max_inflated_bytes = text.size() - 1;
  expect_error([&] { read_carmen_buffer(gz.data(), gz.size(), "bomb.log.gz", settings); },
               {"bomb.log.gz", "max_inflated_bytes"});
  // Members after the first count towards the same cap.
  const std::string two = gzip_stored(text) + gzip_stored(text);
  settings.max_inflated_bytes = 2 * text.size() - 1;
  expect_error([&] { read_carmen_buffer(two.data(), two.size(), "two.log.gz", settings); },
               {"two.log.gz", "max_inflated_bytes"});
}

// Messages the reader skips are not split at all, so their length does not matter.
TEST(ReaderRobustnessTest, CarmenLongUnknownMessageIsSkipped) {
  std::string text = kSmallLog;
  text += "NEFF";
  for (std::size_t i = 0; i < 2000030; ++i) text += " 1";
  text += '\n';
  const CarmenLog log = parse_carmen(text, "neff.log");
  EXPECT_EQ(log.num_skipped, 1u);
  EXPECT_EQ(log.lasers.size(), 1u);
  EXPECT_EQ(log.odometry.size(), 2u);
}

TEST(ReaderRobustnessTest, CarmenBufferReadsGzipAndPlainAlike) {
  const CarmenLog plain = read_carmen_bytes(kSmallLog, "small.log");
  const CarmenLog gz = read_carmen_bytes(gzip_stored(kSmallLog), "small.log.gz");
  ASSERT_EQ(plain.lasers.size(), 1u);
  ASSERT_EQ(gz.lasers.size(), 1u);
  EXPECT_EQ(gz.lasers[0].scan.ranges, plain.lasers[0].scan.ranges);
  EXPECT_EQ(gz.lasers[0].line, 3u);
  EXPECT_EQ(gz.odometry.size(), 2u);
  EXPECT_EQ(gz.params.at("robot_frontlaser_offset"), "0.0");

  // `cat a.gz b.gz`: the members are read in turn, as one text.
  const std::string first = "ODOM 0 0 0 0 0 0 1 h 1\n", second = "ODOM 1 0 0 0 0 0 2 h 2\n";
  const CarmenLog both = read_carmen_bytes(gzip_stored(first) + gzip_stored(second), "two.log.gz");
  ASSERT_EQ(both.odometry.size(), 2u);
  EXPECT_EQ(both.odometry[1].line, 2u);
  EXPECT_EQ(both.odometry[1].pose.x, 1.0);
}

TEST(ReaderRobustnessTest, CarmenBadGzipNamesTheInput) {
  const std::string gz = gzip_stored(kSmallLog);
  expect_error([&] { read_carmen_bytes(gz.substr(0, gz.size() - 12), "cut.log.gz"); },
               {"cut.log.gz", "unexpected end of the gzip data"});
  std::string bad_crc = gz;
  bad_crc[bad_crc.size() - 8] = static_cast<char>(bad_crc[bad_crc.size() - 8] ^ 0x55);
  expect_error([&] { read_carmen_bytes(bad_crc, "crc.log.gz"); }, {"crc.log.gz", "gzip byte"});
  expect_error([&] { read_carmen_bytes(std::string("\x1f\x8b", 2), "header.log.gz"); }, {"header.log.gz"});
}

// ---- wheel encoders --------------------------------------------------------------------------------

// 2 pi ticks / ticks_per_revolution overflowed to an infinite angle, which the reader returned.
TEST(ReaderRobustnessTest, WheelTickCountsTooLargeForAnglesAreAnError) {
  WheelEncoderReadSettings ticks;
  ticks.ticks_per_revolution = 1.0;
  const std::string text = "stamp,left,right\n0,0,0\n0.1,1e308,0\n";
  expect_error([&] { parse_wheel_encoders(text, "wheels.csv", ticks); }, {"wheels.csv:3", "too large"});
  EXPECT_EQ(parse_wheel_encoders(text, "wheels.csv").back().left, 1e308);  // as angles: finite
}

// ---- frame dump --------------------------------------------------------------------------------------

// The duplicate-key check compared each key with all before it: an object of 120k short keys
// (1.2 MB) took five minutes. It must be linear; the bound leaves two orders of margin.
TEST(ReaderRobustnessTest, FrameDumpMetaWithManyKeysIsFastAndNamesADuplicate) {
  std::string text = "{\"T_base_lidar\": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]";
  for (int i = 0; i < 120000; ++i) text += ",\"k" + std::to_string(i) + "\":0";
  const auto start = std::chrono::steady_clock::now();
  EXPECT_NO_THROW(parse_frame_dump_meta(text + "}", "meta.json"));
  expect_error([&] { parse_frame_dump_meta(text + ",\"k7\":1}", "dump/meta.json"); },
               {"dump/meta.json:1:", "duplicate key \"k7\""});
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_LT(seconds, 30.0);
}

TEST(ReaderRobustnessTest, FrameDumpCsvTextNamesFileAndLine) {
  const FrameDumpIndex index =
      parse_frame_dump_frames("index,stamp,file\n0,0.1,frames/000000.pcd\n# note\n1,0.2,frames/000001.pcd\n");
  ASSERT_EQ(index.stamps.size(), 2u);
  EXPECT_EQ(index.files[1], "frames/000001.pcd");
  expect_error([] { parse_frame_dump_frames("index,stamp,file\n0,0.1,a.pcd\n2,0.2,b.pcd\n", "d/frames.csv"); },
               {"d/frames.csv:3", "index 2, expected 1"});
  expect_error([] { parse_frame_dump_odometry("stamp,x,y,theta\n0,0,0,0\n0,1,0,0\n", "d/odom.csv"); },
               {"d/odom.csv:3", "does not increase"});
  expect_error([] { parse_frame_dump_imu("stamp,wx,wy,wz,ax,ay,az\n0,0,0,0,0,0,nan\n", "d/imu.csv"); },
               {"d/imu.csv:2", "az"});
  expect_error([] { parse_frame_dump_imu("stamp,x,y,theta\n", "d/imu.csv"); }, {"d/imu.csv:1", "header"});
}

// ---- trajectories ------------------------------------------------------------------------------------

TEST(ReaderRobustnessTest, TrajectoryTextNamesFileAndLine) {
  EXPECT_EQ(parse_tum("# t x y z qx qy qz qw\n1 0 0 0 0 0 0 1\n", "a.tum").size(), 1u);
  expect_error([] { parse_tum("1 0 0 0 0 0 0 1\n2 0 0 0 0 0 0\n", "a.tum"); }, {"a.tum:2", "expected 8 fields"});
  expect_error([] { parse_kitti("1 0 0 0 0 1 0 0 0 0 2 0\n", "poses.txt"); }, {"poses.txt:1", "not a rotation"});
  expect_error([] { parse_times("0.0\n0.1\nx\n", "times.txt"); }, {"times.txt:3", "not a finite number"});
}

// A directory where a file is expected is named as such by every path reader, instead of an
// allocation failure, a stream error naming nothing, or "no tuples" / an empty cloud.
TEST(ReaderRobustnessTest, ADirectoryGivenAsAFileIsNamedAsSuch) {
  const std::string dir = plumb::test::temp_path("reader_robustness_dir");
  std::filesystem::create_directories(dir + "/meta.json");
  std::filesystem::create_directories(dir + "/frame.pcd");
  expect_error([&] { read_cloud(dir + "/frame.pcd"); }, {dir + "/frame.pcd", "is a directory"});
  expect_error([&] { read_pcd(dir); }, {dir, "is a directory"});
  expect_error([&] { read_ply(dir); }, {dir, "is a directory"});
  expect_error([&] { read_kitti_bin(dir); }, {dir, "is a directory"});
  expect_error([&] { read_carmen(dir); }, {dir, "is a directory"});
  expect_error([&] { read_calib_tuples(dir); }, {dir, "is a directory"});
  expect_error([&] { read_wheel_encoders(dir); }, {dir, "is a directory"});
  // A dump whose meta.json is a directory.
  expect_error([&] { FrameDumpReader{dir}; }, {dir + "/meta.json", "is a directory"});
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace plumb::io
