// SPDX-License-Identifier: BSD-3-Clause
// The ROS 1 bag reader and the message decoders on bags and messages built here byte by byte from
// the format's description (http://wiki.ros.org/Bags/Format/2.0, the ROS 1 serialization), so the
// expected values are the ones written, not what another reader makes of them. Bags written by
// ROS's own rosbag are read in tests/cli/import_cli_test.cpp.
#include <cmath>
#include <cstdint>
#include <cstring>
#include <memory>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "io_test_util.hpp"
#include "plumb/core/error.hpp"
#include "plumb/io/ros_messages.hpp"
#include "plumb/io/rosbag.hpp"
#include "rosbag_builder.hpp"

namespace plumb {
namespace {

using io::BagReader;
using test::expect_error;

using Writer = test::RosWriter;
using HandMessage = test::BagBuilderMessage;

// A bag of one chunk: connections 0 (/a, "pkg/A") and 1 (/b, "pkg/B"), the messages given.
std::string hand_bag(const std::vector<HandMessage>& messages, const std::string& compression = "none",
                     bool with_index = true) {
  return test::build_bag({{"/a", "pkg/A", std::string(32, 'a')}, {"/b", "pkg/B", std::string(32, 'b')}}, messages,
                         1000, compression, with_index);
}

BagReader open_bytes(const std::string& bytes) {
  return BagReader(std::make_unique<std::istringstream>(bytes), "hand.bag");
}

std::vector<HandMessage> three_messages() {
  return {{0, 10, 0, "first"}, {1, 10, 500000000, "other topic"}, {0, 12, 0, "second"}, {0, 14, 0, ""}};
}

TEST(BagReaderTest, ReadsTheRecordsOfAHandBuiltBag) {
  const BagReader bag = open_bytes(hand_bag(three_messages()));
  ASSERT_EQ(bag.connections().size(), 2u);
  EXPECT_EQ(bag.connections()[0].topic, "/a");
  EXPECT_EQ(bag.connections()[1].type, "pkg/B");
  EXPECT_EQ(bag.connections()[1].md5sum, std::string(32, 'b'));
  EXPECT_EQ(bag.connections()[0].message_definition, "# def\n");
  EXPECT_EQ(bag.num_messages(), 4u);
  EXPECT_EQ(bag.num_chunks(), 1u);
  EXPECT_EQ(bag.start_time().sec, 10u);
  EXPECT_EQ(bag.end_time().sec, 14u);
  const auto topics = bag.topics();
  ASSERT_EQ(topics.size(), 2u);
  EXPECT_EQ(topics[0].topic, "/a");
  EXPECT_EQ(topics[0].messages, 3u);
  EXPECT_DOUBLE_EQ(topics[0].rate_hz, 0.5);  // 2 intervals in 4 s
  EXPECT_EQ(topics[1].messages, 1u);
  EXPECT_EQ(topics[1].rate_hz, 0.0);
  EXPECT_EQ(topics[1].first.nsec, 500000000u);

  std::vector<std::string> got;
  std::vector<std::int64_t> times;
  bag.read({0}, [&](const io::BagMessage& m) {
    EXPECT_EQ(m.connection->topic, "/a");
    got.emplace_back(reinterpret_cast<const char*>(m.data), m.size);
    times.push_back(m.time.nanoseconds());
    return true;
  });
  EXPECT_EQ(got, (std::vector<std::string>{"first", "second", ""}));
  EXPECT_EQ(times, (std::vector<std::int64_t>{10000000000, 12000000000, 14000000000}));
  // Both connections in bag order; returning false stops.
  got.clear();
  bag.read({1, 0}, [&](const io::BagMessage& m) {
    got.emplace_back(reinterpret_cast<const char*>(m.data), m.size);
    return got.size() < 2;
  });
  EXPECT_EQ(got, (std::vector<std::string>{"first", "other topic"}));
}

TEST(BagReaderTest, EveryTruncationFailsNamingTheOffset) {
  const std::string bytes = hand_bag(three_messages());
  for (std::size_t keep = 0; keep < bytes.size(); ++keep) {
    SCOPED_TRACE(keep);
    expect_error(
        [&] {
          const BagReader bag = open_bytes(bytes.substr(0, keep));
          bag.topics();
          bag.read({0, 1}, [](const io::BagMessage&) { return true; });
        },
        {"hand.bag: offset "});
  }
}

TEST(BagReaderTest, EveryFlippedByteReadsOrFailsCleanly) {
  const std::string bytes = hand_bag(three_messages());
  for (std::size_t at = 0; at < bytes.size(); ++at) {
    std::string bad = bytes;
    bad[at] = static_cast<char>(bad[at] ^ 0xff);
    try {
      const BagReader bag = open_bytes(bad);
      bag.topics();
      bag.read({0, 1}, [](const io::BagMessage&) { return true; });
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("hand.bag"), std::string::npos) << e.what();
    }
  }
}

TEST(BagReaderTest, RefusesWhatItDoesNotRead) {
  expect_error([] { open_bytes("#ROSBAG V1.2\nold"); }, {"hand.bag: offset 0", "other versions are not read"});
  expect_error([] { open_bytes("PK\x03\x04 a zip file, not a bag"); }, {"hand.bag: offset 0", "not a ROS bag"});
  expect_error([] { open_bytes(hand_bag(three_messages(), "none", false)); }, {"no index", "rosbag reindex"});
  const BagReader zstd = open_bytes(hand_bag(three_messages(), "zstd"));
  expect_error([&] { zstd.read({0}, [](const io::BagMessage&) { return true; }); },
               {"hand.bag: offset ", "unsupported chunk compression 'zstd'"});
}

// ---- sensor_msgs/PointCloud2 -----------------------------------------------------------------------

using FieldSpec = test::RosPointField;

std::vector<std::uint8_t> bytes_of(const std::string& s) { return {s.begin(), s.end()}; }

io::RosPointCloud2 decode(const std::string& message) {
  const std::vector<std::uint8_t> b = bytes_of(message);
  return io::decode_point_cloud2(b.data(), b.size());
}

// Points of 32 bytes: y float32 at 0, x float64 at 8, z int16 at 16 [the raw value], reflectivity
// uint8 at 18, channel uint16 at 20, t uint32 [ns] at 24, the rest padding; rows padded by 8 bytes.
TEST(RosPointCloud2Test, PaddedFieldsInEitherByteOrderMatchTheValuesWritten) {
  const std::vector<FieldSpec> fields = {{"y", 0, 7},  {"x", 8, 8},        {"z", 16, 3},
                                         {"reflectivity", 18, 2}, {"channel", 20, 4}, {"t", 24, 6}};
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> coord(-50, 50);
  for (const bool big : {false, true}) {
    SCOPED_TRACE(big);
    const std::uint32_t height = 3, width = 5, point_step = 32, row_step = 32 * 5 + 8;
    std::vector<double> xs, ys, zs, refl, ring, t;
    std::string data;
    for (std::uint32_t r = 0; r < height; ++r) {
      for (std::uint32_t c = 0; c < width; ++c) {
        xs.push_back(coord(rng));
        ys.push_back(static_cast<float>(coord(rng)));
        zs.push_back(static_cast<int>(rng() % 60000) - 30000);
        refl.push_back(rng() % 256);
        ring.push_back(rng() % 128);
        t.push_back(rng() % 100000000);
        Writer p;
        p.put(static_cast<float>(ys.back()), big).put<std::uint32_t>(0xdeadbeef).put(xs.back(), big);
        p.put(static_cast<std::int16_t>(zs.back()), big).put(static_cast<std::uint8_t>(refl.back()));
        p.put<std::uint8_t>(0x55).put(static_cast<std::uint16_t>(ring.back()), big).put<std::uint16_t>(0x7777);
        p.put(static_cast<std::uint32_t>(t.back()), big).put<std::uint32_t>(0xffffffff);
        ASSERT_EQ(p.s.size(), point_step);
        data += p.s;
      }
      data += std::string(8, '\xab');
    }
    const io::RosPointCloud2 pc =
        decode(test::ros_point_cloud2(100, 250, height, width, fields, big, point_step, row_step, data));
    EXPECT_EQ(pc.header.stamp.nanoseconds(), 100000000250);
    EXPECT_EQ(pc.header.frame_id, "lidar");
    EXPECT_EQ(pc.time_field, io::PointTimeField::kT);
    ASSERT_EQ(pc.cloud.size(), xs.size());
    ASSERT_TRUE(pc.cloud.has_intensities() && pc.cloud.has_rings() && pc.cloud.has_times());
    for (std::size_t i = 0; i < xs.size(); ++i) {
      EXPECT_EQ(pc.cloud.points[i].x(), static_cast<float>(xs[i])) << i;
      EXPECT_EQ(pc.cloud.points[i].y(), static_cast<float>(ys[i])) << i;
      EXPECT_EQ(pc.cloud.points[i].z(), static_cast<float>(zs[i])) << i;
      EXPECT_EQ(pc.cloud.intensities[i], static_cast<float>(refl[i])) << i;
      EXPECT_EQ(pc.cloud.rings[i], ring[i]) << i;
      EXPECT_EQ(pc.cloud.times[i], static_cast<float>(t[i] * 1e-9)) << i;
    }
  }
}

TEST(RosPointCloud2Test, TheTimeFieldsOfTheDrivers) {
  // Velodyne: `time` float32 [s] since the stamp; intensity and ring by those names.
  Writer v;
  v.put(1.0f).put(2.0f).put(3.0f).put(40.0f).put<std::uint16_t>(7).put(0.025f);
  io::RosPointCloud2 pc = decode(test::ros_point_cloud2(
      5, 0, 1, 1, {{"x", 0, 7}, {"y", 4, 7}, {"z", 8, 7}, {"intensity", 12, 7}, {"ring", 16, 4}, {"time", 18, 7}},
      false, 22, 22, v.s));
  EXPECT_EQ(pc.time_field, io::PointTimeField::kTime);
  EXPECT_EQ(pc.cloud.times[0], 0.025f);
  EXPECT_EQ(pc.cloud.rings[0], 7);
  EXPECT_EQ(pc.cloud.intensities[0], 40.0f);
  // Hesai / Livox: `timestamp` float64, absolute [s]: the stamp is subtracted.
  Writer h;
  h.put(1.0f).put(2.0f).put(3.0f).put(1700000000.0625);
  pc = decode(test::ros_point_cloud2(1700000000, 50000000, 1, 1, {{"x", 0, 7}, {"y", 4, 7}, {"z", 8, 7}, {"timestamp", 12, 8}},
                            false, 20, 20, h.s));
  EXPECT_EQ(pc.time_field, io::PointTimeField::kTimestamp);
  EXPECT_NEAR(pc.cloud.times[0], 0.0125, 1e-6);
  EXPECT_FALSE(pc.cloud.has_rings());
  // No time field: none.
  pc = decode(test::ros_point_cloud2(1, 0, 1, 1, {{"x", 0, 7}, {"y", 4, 7}, {"z", 8, 7}}, false, 12, 12, h.s.substr(0, 12)));
  EXPECT_EQ(pc.time_field, io::PointTimeField::kNone);
  EXPECT_FALSE(pc.cloud.has_times());
}

TEST(RosPointCloud2Test, InconsistentMessagesFailSayingWhy) {
  const std::vector<FieldSpec> xyz = {{"x", 0, 7}, {"y", 4, 7}, {"z", 8, 7}};
  const std::string data(24, '\0');
  expect_error([&] { decode(test::ros_point_cloud2(1, 0, 1, 2, {{"x", 0, 7}, {"y", 4, 7}}, false, 12, 24, data)); },
               {"x, y and z are required"});
  expect_error([&] { decode(test::ros_point_cloud2(1, 0, 1, 2, {{"x", 0, 7}, {"y", 4, 7}, {"z", 10, 7}}, false, 12, 24, data)); },
               {"'z' at offset 10", "point_step 12"});
  expect_error([&] { decode(test::ros_point_cloud2(1, 0, 1, 3, xyz, false, 12, 24, data)); }, {"exceeds row_step"});
  expect_error([&] { decode(test::ros_point_cloud2(1, 0, 2, 2, xyz, false, 12, 24, data)); }, {"exceeds the data"});
  expect_error([&] { decode(test::ros_point_cloud2(1, 0, 1, 2, {{"x", 0, 9}, {"y", 4, 7}, {"z", 8, 7}}, false, 12, 24, data)); },
               {"datatype 9"});
  const std::string whole = test::ros_point_cloud2(1, 0, 1, 2, xyz, false, 12, 24, data);
  for (std::size_t keep = 0; keep + 1 < whole.size(); ++keep) {  // the last byte (is_dense) is not read
    expect_error([&] { decode(whole.substr(0, keep)); }, {"PointCloud2: message cut short"});
  }
}

// ---- Imu, Odometry, TFMessage ------------------------------------------------------------------

TEST(RosMessagesTest, ImuOdometryAndTransformsReadTheValuesWritten) {
  Writer imu;
  imu.header(3, 500, "imu");
  for (double v : {0.0, 0.0, 0.0, 1.0}) imu.put(v);
  for (int k = 0; k < 9; ++k) imu.put(-1.0);
  imu.put(0.1).put(-0.2).put(0.3);
  for (int k = 0; k < 9; ++k) imu.put(-1.0);
  imu.put(1.5).put(2.5).put(9.81);
  for (int k = 0; k < 9; ++k) imu.put(-1.0);
  const auto ib = bytes_of(imu.s);
  const io::RosImu i = io::decode_imu(ib.data(), ib.size());
  EXPECT_EQ(i.header.frame_id, "imu");
  EXPECT_EQ(i.sample.stamp, 3.0000005);
  EXPECT_EQ(i.sample.gyro, Eigen::Vector3d(0.1, -0.2, 0.3));
  EXPECT_EQ(i.sample.accel, Eigen::Vector3d(1.5, 2.5, 9.81));
  expect_error([&] { io::decode_imu(ib.data(), ib.size() - 1); }, {"Imu: message cut short"});

  const double half = 0.25;  // a turn of 0.5 rad about z
  Writer od;
  od.header(4, 0, "odom").str("base_link").put(1.0).put(2.0).put(0.0);
  od.put(0.0).put(0.0).put(std::sin(half)).put(std::cos(half));
  for (int k = 0; k < 36 + 6 + 36; ++k) od.put(0.0);
  const auto ob = bytes_of(od.s);
  const io::RosOdometry o = io::decode_odometry(ob.data(), ob.size());
  EXPECT_EQ(o.child_frame_id, "base_link");
  EXPECT_EQ(o.pose.translation(), Eigen::Vector3d(1, 2, 0));
  EXPECT_TRUE(o.pose.linear().isApprox(Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitZ()).toRotationMatrix(), 1e-15));

  // /tf_static: base_link -> mount (translation), mount -> lidar (a quarter turn about x).
  Writer tf;
  tf.u32(2);
  tf.header(0, 0, "/base_link").str("mount").put(0.5).put(0.0).put(1.0).put(0.0).put(0.0).put(0.0).put(1.0);
  tf.header(0, 0, "mount").str("lidar").put(0.0).put(0.1).put(0.0);
  tf.put(std::sqrt(0.5)).put(0.0).put(0.0).put(std::sqrt(0.5));
  const auto tb = bytes_of(tf.s);
  const std::vector<io::RosTransform> tree = io::decode_tf_message(tb.data(), tb.size());
  ASSERT_EQ(tree.size(), 2u);
  Eigen::Isometry3d T;
  ASSERT_TRUE(io::resolve_transform(tree, "base_link", "lidar", T));
  EXPECT_TRUE(T.translation().isApprox(Eigen::Vector3d(0.5, 0.1, 1.0), 1e-15));
  EXPECT_TRUE(T.linear().isApprox(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitX()).toRotationMatrix(), 1e-15));
  EXPECT_FALSE(io::resolve_transform(tree, "base_link", "camera", T));
  EXPECT_FALSE(io::resolve_transform(tree, "chassis", "lidar", T));
  // A zero quaternion is no rotation.
  Writer zero;
  zero.u32(1).header(0, 0, "a").str("b");
  for (int k = 0; k < 7; ++k) zero.put(0.0);
  const auto zb = bytes_of(zero.s);
  expect_error([&] { io::decode_tf_message(zb.data(), zb.size()); }, {"TFMessage", "not a rotation"});
}

TEST(RosMessagesTest, SynthesisedTimesFollowTheAzimuth) {
  // 4 rings x 360 columns, fired in order, turning counter-clockwise or clockwise from 30 degrees.
  const double period = 0.1;
  for (const double turn : {1.0, -1.0}) {
    SCOPED_TRACE(turn);
    PointCloud cloud;
    std::vector<double> want;
    for (int c = 0; c < 360; ++c) {
      const double az = (30.0 + turn * c) * M_PI / 180.0;
      for (int r = 0; r < 4; ++r) {
        cloud.points.emplace_back(static_cast<float>(5 * std::cos(az)), static_cast<float>(5 * std::sin(az)),
                                  static_cast<float>(r - 2));
        want.push_back(c / 360.0 * period);
      }
    }
    io::synthesise_point_times(cloud, period);
    ASSERT_EQ(cloud.times.size(), want.size());
    for (std::size_t i = 0; i < want.size(); ++i) EXPECT_NEAR(cloud.times[i], want[i], 1e-6) << i;
  }
  PointCloud one;
  one.points.emplace_back(1.0f, 0.0f, 0.0f);
  expect_error([&] { io::synthesise_point_times(one, 0.0); }, {"period"});
}

}  // namespace
}  // namespace plumb
