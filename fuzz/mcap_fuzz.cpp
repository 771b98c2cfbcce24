// SPDX-License-Identifier: BSD-3-Clause
// libFuzzer target for MCAP files: McapReader must either open the file or throw plumb::Error, and
// what it opened must list its topics and stream every message of every channel (each decoded by
// its type's CDR decoder when it has one) or throw plumb::Error, never crash or hang (ASan checks
// that every message handed out lies inside its chunk or record).
// Seeds: fuzz/seeds/mcap/*.mcap (tiny hand-made files: a chunk of each compression with a summary
// and message indexes, one without a summary, one without chunks; CDR Imu and PointCloud2; one
// JointState).
#include <cstddef>
#include <cstdint>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "plumb/core/error.hpp"
#include "plumb/io/mcap.hpp"
#include "plumb/io/ros_messages.hpp"

#include "fuzz_require.hpp"

// Names this target in the messages of FUZZ_REQUIRE.
constexpr const char* kFuzzTarget = "mcap_fuzz";

namespace {

void decode(const std::string& type, const plumb::io::McapMessage& m) {
  constexpr auto kCdr = plumb::io::RosSerialization::kCdr;
  try {
    if (type == "sensor_msgs/msg/PointCloud2") {
      const plumb::io::RosPointCloud2 pc = plumb::io::decode_point_cloud2(m.data, m.size, kCdr);
      pc.cloud.check_consistent("mcap_fuzz");
    } else if (type == "sensor_msgs/msg/Imu") {
      plumb::io::decode_imu(m.data, m.size, kCdr);
    } else if (type == "nav_msgs/msg/Odometry") {
      plumb::io::decode_odometry(m.data, m.size, kCdr);
    } else if (type == "tf2_msgs/msg/TFMessage") {
      plumb::io::decode_tf_message(m.data, m.size, kCdr);
    } else if (type == "sensor_msgs/msg/JointState") {
      plumb::io::decode_joint_state(m.data, m.size, kCdr);
    }
  } catch (const plumb::Error&) {
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  auto in = std::make_unique<std::istringstream>(std::string(reinterpret_cast<const char*>(data), size));
  try {
    const plumb::io::McapReader mcap(std::move(in), "fuzz.mcap");
    mcap.topics();
    mcap.compression();
    mcap.num_messages();
    mcap.start_time();
    std::vector<std::uint16_t> ids;
    for (const plumb::io::McapChannel& c : mcap.channels()) ids.push_back(c.id);
    mcap.read(ids, [&](const plumb::io::McapMessage& m) {
      FUZZ_REQUIRE(m.channel != nullptr && (m.size == 0 || m.data != nullptr));
      const plumb::io::McapSchema* s = mcap.schema(*m.channel);
      decode(s != nullptr ? s->name : "", m);
      return true;
    });
    std::vector<std::string> topics;
    for (const plumb::io::BagTopic& t : mcap.topics()) topics.push_back(t.topic);
    mcap.read_topics(topics, [](const plumb::io::RecordedMessage&) { return true; });
  } catch (const plumb::Error&) {
  }
  return 0;
}
