// SPDX-License-Identifier: BSD-3-Clause
// McapReader on hand-built MCAP files (the records written here field by field from the
// specification, https://mcap.dev/spec), and the CDR decoders on hand-built ROS 2 messages.
#include <algorithm>
#include <cstdint>
#include <cstring>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "plumb/core/error.hpp"
#include "plumb/io/mcap.hpp"
#include "plumb/io/ros_messages.hpp"
#include "mcap_builder.hpp"

namespace plumb {
namespace {

using Le = test::McapFields;
using test::crc32_of;
using test::mcap_record;
const auto& record = mcap_record;

const std::string& kMagic = test::kMcapMagicBytes;

std::string header() { return record(0x01, Le().str("ros2").str("plumb test").s); }
std::string schema() {
  return record(0x03, Le().num<std::uint16_t>(1).str("sensor_msgs/msg/Imu").str("ros2msg").str("float64 x").s);
}
std::string channel() {
  return record(0x04, Le().num<std::uint16_t>(7).num<std::uint16_t>(1).str("/imu").str("cdr").num<std::uint32_t>(0).s);
}
std::string message(std::uint64_t t, const std::string& data) {
  return record(0x05, Le().num<std::uint16_t>(7).num<std::uint32_t>(0).num(t).num(t).s + data);
}
std::string chunk(const std::string& records, std::uint64_t start, std::uint64_t end, bool good_crc = true) {
  Le c;
  c.num(start).num(end).num<std::uint64_t>(records.size()).num<std::uint32_t>(crc32_of(records) + (good_crc ? 0 : 1));
  c.str("").num<std::uint64_t>(records.size());
  return record(0x06, c.s + records);
}
std::string footer(std::uint64_t summary_start) {
  return record(0x02, Le().num(summary_start).num<std::uint64_t>(0).num<std::uint32_t>(0).s);
}
std::string data_end() { return record(0x0F, Le().num<std::uint32_t>(0).s); }

// Three messages, out of log-time order, in one chunk; no summary.
std::string unindexed_file(bool good_crc = true) {
  const std::string records = schema() + channel() + message(30, "c") + message(10, "a") + message(20, "b");
  return kMagic + header() + chunk(records, 10, 30, good_crc) + data_end() + footer(0) + kMagic;
}

// The same with the message index after the chunk and a summary: schema, channel, statistics, chunk index.
std::string indexed_file() {
  const std::string records = schema() + channel() + message(30, "c") + message(10, "a") + message(20, "b");
  std::string f = kMagic + header();
  const std::uint64_t chunk_pos = f.size();
  f += chunk(records, 10, 30);
  const std::uint64_t chunk_length = f.size() - chunk_pos;
  const std::uint64_t index_pos = f.size();
  Le entries;
  entries.num<std::uint64_t>(30).num<std::uint64_t>(0).num<std::uint64_t>(10).num<std::uint64_t>(0);
  entries.num<std::uint64_t>(20).num<std::uint64_t>(0);
  f += record(0x07, Le().num<std::uint16_t>(7).str(entries.s).s);
  f += data_end();
  const std::uint64_t summary = f.size();
  f += schema() + channel();
  Le stats;
  stats.num<std::uint64_t>(3).num<std::uint16_t>(1).num<std::uint32_t>(1).num<std::uint32_t>(0).num<std::uint32_t>(0);
  stats.num<std::uint32_t>(1).num<std::uint64_t>(10).num<std::uint64_t>(30).str(Le().num<std::uint16_t>(7).num<std::uint64_t>(3).s);
  f += record(0x0B, stats.s);
  Le ci;
  ci.num<std::uint64_t>(10).num<std::uint64_t>(30).num(chunk_pos).num(chunk_length);
  ci.str(Le().num<std::uint16_t>(7).num(index_pos).s).num<std::uint64_t>(f.size() - index_pos);
  ci.str("").num<std::uint64_t>(0).num<std::uint64_t>(0);
  f += record(0x08, ci.s);
  return f + footer(summary) + kMagic;
}

std::unique_ptr<io::McapReader> reader(const std::string& bytes) {
  return std::make_unique<io::McapReader>(std::make_unique<std::istringstream>(bytes), "test.mcap");
}

// The log times and payloads read_topics() hands out.
std::vector<std::pair<std::int64_t, std::string>> messages(const io::McapReader& r) {
  std::vector<std::pair<std::int64_t, std::string>> out;
  r.read_topics({"/imu"}, [&](const io::RecordedMessage& m) {
    EXPECT_EQ(*m.topic, "/imu");
    EXPECT_EQ(m.serialization, io::RosSerialization::kCdr);
    out.emplace_back(m.time.nanoseconds(), std::string(reinterpret_cast<const char*>(m.data), m.size));
    return true;
  });
  return out;
}

const std::vector<std::pair<std::int64_t, std::string>> kInOrder = {{10, "a"}, {20, "b"}, {30, "c"}};

TEST(McapReaderTest, WithoutASummaryTheDataSectionIsScanned) {
  const auto r = reader(unindexed_file());
  EXPECT_FALSE(r->has_summary());
  ASSERT_EQ(r->channels().size(), 1u);
  EXPECT_EQ(r->channels()[0].topic, "/imu");
  ASSERT_NE(r->schema(r->channels()[0]), nullptr);
  EXPECT_EQ(r->schema(r->channels()[0])->name, "sensor_msgs/msg/Imu");
  EXPECT_EQ(r->num_messages(), 3u);
  EXPECT_EQ(r->start_time().nanoseconds(), 10);
  EXPECT_EQ(r->end_time().nanoseconds(), 30);
  EXPECT_EQ(r->num_chunks(), 1u);
  EXPECT_EQ(r->compression(), (std::vector<std::pair<std::string, std::size_t>>{{"none", 1}}));
  const auto topics = r->topics();
  ASSERT_EQ(topics.size(), 1u);
  EXPECT_EQ(topics[0].type, "sensor_msgs/msg/Imu");
  EXPECT_EQ(topics[0].messages, 3u);
  EXPECT_EQ(topics[0].first.nanoseconds(), 10);
  EXPECT_EQ(topics[0].last.nanoseconds(), 30);
  EXPECT_NEAR(topics[0].rate_hz, 2 / 20e-9, 1e-3);
  EXPECT_EQ(messages(*r), kInOrder);  // in log-time order
}

TEST(McapReaderTest, WithASummaryTheIndexesAreRead) {
  const auto r = reader(indexed_file());
  EXPECT_TRUE(r->has_summary());
  EXPECT_EQ(r->num_messages(), 3u);
  EXPECT_EQ(r->start_time().nanoseconds(), 10);
  EXPECT_EQ(r->end_time().nanoseconds(), 30);
  const auto topics = r->topics();
  ASSERT_EQ(topics.size(), 1u);
  EXPECT_EQ(topics[0].messages, 3u);
  EXPECT_EQ(topics[0].first.nanoseconds(), 10);
  EXPECT_EQ(topics[0].last.nanoseconds(), 30);
  EXPECT_EQ(messages(*r), kInOrder);
  r->check_type("/imu", "sensor_msgs/Imu");
  EXPECT_THROW(r->check_type("/imu", "sensor_msgs/PointCloud2"), Error);
}

// `f` with the footer's summary CRC32 set: over the summary up to the footer's summary_offset_start.
std::string with_summary_crc(std::string f) {
  const std::size_t footer = f.size() - kMagic.size() - 29;
  std::uint64_t summary = 0;
  std::memcpy(&summary, f.data() + footer + 9, 8);
  const std::uint32_t crc = crc32_of(f.substr(summary, footer + 25 - summary));
  std::memcpy(&f[footer + 25], &crc, 4);
  return f;
}

TEST(McapReaderTest, TheSummaryCrcIsChecked) {
  const std::string f = with_summary_crc(indexed_file());
  EXPECT_EQ(messages(*reader(f)), kInOrder);
  std::string bad = f;
  const std::size_t footer = f.size() - kMagic.size() - 29;
  bad[footer - 20] = static_cast<char>(bad[footer - 20] ^ 1);  // in the chunk index
  try {
    reader(bad);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("test.mcap: offset " + std::to_string(footer) + ": summary CRC32"),
              std::string::npos)
        << e.what();
  }
}

TEST(McapReaderTest, MessagesOutsideChunks) {
  const std::string f = kMagic + header() + schema() + channel() + message(10, "a") + message(20, "b") + data_end() +
                        footer(0) + kMagic;
  const auto r = reader(f);
  EXPECT_EQ(r->num_chunks(), 0u);
  EXPECT_EQ(r->num_messages(), 2u);
  EXPECT_EQ(messages(*r), (std::vector<std::pair<std::int64_t, std::string>>{{10, "a"}, {20, "b"}}));
}

TEST(McapReaderTest, AChunkWhoseCrcDiffersIsAnErrorNamingItsOffset) {
  try {
    reader(unindexed_file(false));  // the scan reads the chunk
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("test.mcap: offset " + std::to_string(kMagic.size() + header().size()) +
                                         ": chunk CRC32"),
              std::string::npos)
        << e.what();
  }
}

TEST(McapReaderTest, EveryTruncationAndEveryDamagedByteIsAnErrorOrReadsNeverACrash) {
  for (const std::string& whole : {unindexed_file(), indexed_file()}) {
    for (std::size_t n = 0; n < whole.size(); ++n) {
      try {
        const auto r = reader(whole.substr(0, n));
        messages(*r);
        ADD_FAILURE() << "a file cut to " << n << " bytes was read";
      } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("test.mcap: offset "), std::string::npos) << e.what();
      }
    }
    for (std::size_t i = 0; i < whole.size(); ++i) {
      std::string bad = whole;
      bad[i] = static_cast<char>(bad[i] ^ 0xff);
      try {
        const auto r = reader(bad);
        r->topics();
        messages(*r);
      } catch (const Error&) {
      }
    }
  }
}

TEST(McapReaderTest, NotMcapIsRefused) {
  EXPECT_THROW(reader("#ROSBAG V2.0\n"), Error);
  EXPECT_THROW(reader(kMagic + header() + footer(0)), Error);  // no closing magic
  // A summary that starts outside the file.
  EXPECT_THROW(reader(kMagic + header() + data_end() + footer(1u << 30) + kMagic), Error);
}

using Cdr = test::CdrFields;

TEST(CdrDecodeTest, ImuInEitherByteOrder) {
  for (const bool big : {false, true}) {
    Cdr c(big);
    c.header(12, 345, "imu_link");  // 13 bytes of string: padding before the float64s
    for (double q : {0.0, 0.0, 0.0, 1.0}) c.num(q);
    for (int i = 0; i < 9; ++i) c.num(0.0);
    c.num(0.1).num(-0.2).num(0.3);
    for (int i = 0; i < 9; ++i) c.num(0.0);
    c.num(1.5).num(2.5).num(-9.81);
    for (int i = 0; i < 9; ++i) c.num(0.0);
    const io::RosImu imu = io::decode_imu(c.data(), c.s.size(), io::RosSerialization::kCdr);
    EXPECT_EQ(imu.header.stamp.sec, 12u);
    EXPECT_EQ(imu.header.stamp.nsec, 345u);
    EXPECT_EQ(imu.header.frame_id, "imu_link");
    EXPECT_EQ(imu.sample.gyro, Eigen::Vector3d(0.1, -0.2, 0.3));
    EXPECT_EQ(imu.sample.accel, Eigen::Vector3d(1.5, 2.5, -9.81));
    EXPECT_DOUBLE_EQ(imu.sample.stamp, 12.000000345);
    // Cut short anywhere: an error, not a read past the end.
    for (std::size_t n = 0; n < c.s.size(); ++n) {
      EXPECT_THROW(io::decode_imu(c.data(), n, io::RosSerialization::kCdr), Error) << n;
    }
  }
}

TEST(CdrDecodeTest, PointCloud2AndItsAlignment) {
  for (const bool big : {false, true}) {
    Cdr c(big);
    c.header(100, 5, "lidar");
    c.num<std::uint32_t>(1).num<std::uint32_t>(2);  // height, width
    c.num<std::uint32_t>(4);
    const char* names[] = {"x", "y", "z", "time"};
    for (std::uint32_t i = 0; i < 4; ++i) c.str(names[i]).num<std::uint32_t>(4 * i).num<std::uint8_t>(7).num<std::uint32_t>(1);
    c.num<std::uint8_t>(0);  // is_bigendian: the point data is little-endian whatever the CDR order
    c.num<std::uint32_t>(16).num<std::uint32_t>(32);
    std::string points;
    for (float v : {1.0f, 2.0f, 3.0f, 0.0f, -4.0f, 5.5f, 6.0f, 0.05f}) points.append(reinterpret_cast<const char*>(&v), 4);
    c.num<std::uint32_t>(32);
    c.s += points;
    c.num<std::uint8_t>(1);
    const io::RosPointCloud2 pc = io::decode_point_cloud2(c.data(), c.s.size(), io::RosSerialization::kCdr);
    EXPECT_EQ(pc.header.frame_id, "lidar");
    EXPECT_EQ(pc.header.stamp.sec, 100u);
    ASSERT_EQ(pc.cloud.size(), 2u);
    EXPECT_EQ(pc.cloud.points[1], Vector3f(-4.0f, 5.5f, 6.0f));
    EXPECT_EQ(pc.time_field, io::PointTimeField::kTime);
    EXPECT_EQ(pc.cloud.times[1], 0.05f);
  }
}

TEST(CdrDecodeTest, TransformsAndOdometry) {
  Cdr tf(false);
  tf.num<std::uint32_t>(2);
  for (int i = 0; i < 2; ++i) {
    tf.header(1, 0, "base_link").str(i == 0 ? "lidar" : "imu");
    tf.num(1.0 + i).num(2.0).num(3.0).num(0.0).num(0.0).num(0.0).num(1.0);
  }
  const auto t = io::decode_tf_message(tf.data(), tf.s.size(), io::RosSerialization::kCdr);
  ASSERT_EQ(t.size(), 2u);
  EXPECT_EQ(t[1].child_frame_id, "imu");
  EXPECT_EQ(t[1].T_parent_child.translation(), Eigen::Vector3d(2, 2, 3));
  Cdr od(true);
  od.header(3, 0, "odom").str("base_link").num(1.0).num(2.0).num(0.0).num(0.0).num(0.0).num(0.0).num(1.0);
  for (int i = 0; i < 36 + 6 + 36; ++i) od.num(0.0);
  const io::RosOdometry o = io::decode_odometry(od.data(), od.s.size(), io::RosSerialization::kCdr);
  EXPECT_EQ(o.child_frame_id, "base_link");
  EXPECT_EQ(o.pose.translation(), Eigen::Vector3d(1, 2, 0));
}

TEST(CdrDecodeTest, JointStateInEitherByteOrder) {
  for (const bool big : {false, true}) {
    Cdr c(big);
    c.header(7, 8, "").num<std::uint32_t>(2).str("wheel_left").str("wheel_right");
    c.num<std::uint32_t>(2).num(1.25).num(-2.5);                // position, aligned to 8 after the count
    c.num<std::uint32_t>(0).num<std::uint32_t>(0);              // velocity, effort
    const io::RosJointState js = io::decode_joint_state(c.data(), c.s.size(), io::RosSerialization::kCdr);
    EXPECT_EQ(js.name, (std::vector<std::string>{"wheel_left", "wheel_right"}));
    EXPECT_EQ(js.position, (std::vector<double>{1.25, -2.5}));
  }
  Cdr bad(false);
  bad.header(7, 8, "").num<std::uint32_t>(2).str("a").str("b").num<std::uint32_t>(1).num(1.0);
  EXPECT_THROW(io::decode_joint_state(bad.data(), bad.s.size(), io::RosSerialization::kCdr), Error);
}

TEST(CdrDecodeTest, BadEncapsulationOrStampIsRefused) {
  Cdr pl(false);
  pl.s[1] = '\3';  // PL_CDR_LE
  pl.num<std::uint32_t>(0);
  EXPECT_THROW(io::decode_tf_message(pl.data(), pl.s.size(), io::RosSerialization::kCdr), Error);
  Cdr neg(false);
  neg.num<std::uint32_t>(1).header(-5, 0, "a").str("b");
  for (int i = 0; i < 7; ++i) neg.num(i == 6 ? 1.0 : 0.0);
  EXPECT_THROW(io::decode_tf_message(neg.data(), neg.s.size(), io::RosSerialization::kCdr), Error);
  EXPECT_THROW(io::decode_tf_message(neg.data(), 2, io::RosSerialization::kCdr), Error);
}

}  // namespace
}  // namespace plumb
