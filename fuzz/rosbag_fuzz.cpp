// SPDX-License-Identifier: BSD-3-Clause
// libFuzzer target for ROS 1 bags: BagReader must either open the bag or throw plumb::Error, and
// what it opened must list its topics and stream every message of every connection (each decoded
// by its type's decoder when it has one) or throw plumb::Error, never crash or hang (ASan checks
// that every message handed out lies inside its chunk).
// Seeds: fuzz/seeds/rosbag/*.bag (tiny bags written by Debian's python3-rosbag: none, bz2, lz4).
#include <cstddef>
#include <cstdint>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "plumb/core/error.hpp"
#include "plumb/io/ros_messages.hpp"
#include "plumb/io/rosbag.hpp"

#include "fuzz_require.hpp"

// Names this target in the messages of FUZZ_REQUIRE.
constexpr const char* kFuzzTarget = "rosbag_fuzz";

namespace {

void decode(const plumb::io::BagMessage& m) {
  const std::string& type = m.connection->type;
  try {
    if (type == "sensor_msgs/PointCloud2") {
      const plumb::io::RosPointCloud2 pc = plumb::io::decode_point_cloud2(m.data, m.size);
      pc.cloud.check_consistent("rosbag_fuzz");
    } else if (type == "sensor_msgs/Imu") {
      plumb::io::decode_imu(m.data, m.size);
    } else if (type == "nav_msgs/Odometry") {
      plumb::io::decode_odometry(m.data, m.size);
    } else if (type == "tf2_msgs/TFMessage") {
      plumb::io::decode_tf_message(m.data, m.size);
    } else if (type == "sensor_msgs/JointState") {
      plumb::io::decode_joint_state(m.data, m.size);
    }
  } catch (const plumb::Error&) {
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  auto in = std::make_unique<std::istringstream>(std::string(reinterpret_cast<const char*>(data), size));
  try {
    const plumb::io::BagReader bag(std::move(in), "fuzz.bag");
    bag.topics();
    bag.compression();
    std::vector<std::uint32_t> ids;
    for (const plumb::io::BagConnection& c : bag.connections()) ids.push_back(c.id);
    bag.read(ids, [&](const plumb::io::BagMessage& m) {
      FUZZ_REQUIRE(m.connection != nullptr && (m.size == 0 || m.data != nullptr));
      decode(m);
      return true;
    });
  } catch (const plumb::Error&) {
  }
  return 0;
}
