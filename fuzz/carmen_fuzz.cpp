// SPDX-License-Identifier: BSD-3-Clause
// libFuzzer target for the plain-text CARMEN log parser: parse_carmen must either return a
// consistent log or throw plumb::Error; the raw-odometry lookup runs on whatever it returned.
// Seeds: fuzz/seeds/carmen/*.log (one of each message kind).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>

#include "plumb/core/error.hpp"
#include "plumb/io/carmen.hpp"

#include "fuzz_require.hpp"

// Names this target in the messages of FUZZ_REQUIRE.
constexpr const char* kFuzzTarget = "carmen_fuzz";

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const plumb::io::CarmenLog log = plumb::io::parse_carmen(text, "fuzz.log");
    std::size_t previous_line = 0;
    for (const plumb::io::CarmenLaser& laser : log.lasers) {
      laser.scan.check_consistent("carmen_fuzz");
      FUZZ_REQUIRE(laser.line > previous_line);
      FUZZ_REQUIRE(laser.num_odometry_before <= log.odometry.size());
      FUZZ_REQUIRE(std::isfinite(laser.ipc_timestamp) && std::isfinite(laser.logger_timestamp));
      FUZZ_REQUIRE(laser.scan.stamp == laser.ipc_timestamp);
      FUZZ_REQUIRE(std::isfinite(laser.pose.x) && std::isfinite(laser.pose.theta));
      FUZZ_REQUIRE(std::isfinite(laser.odom_pose.x) && std::isfinite(laser.odom_pose.theta));
      previous_line = laser.line;
    }
    for (const plumb::io::CarmenOdometry& odom : log.odometry) {
      FUZZ_REQUIRE(odom.ipc_timestamp != 0.0 && std::isfinite(odom.ipc_timestamp));
      FUZZ_REQUIRE(std::isfinite(odom.pose.x) && std::isfinite(odom.pose.y) && std::isfinite(odom.pose.theta));
    }
    const auto poses = plumb::io::raw_odometry_at_lasers(log);
    FUZZ_REQUIRE(poses.size() == log.lasers.size());
  } catch (const plumb::Error&) {
  }
  return 0;
}
