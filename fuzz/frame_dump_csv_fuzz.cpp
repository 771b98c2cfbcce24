// SPDX-License-Identifier: BSD-3-Clause
// libFuzzer target for a frame dump's CSV files: the same bytes go to the frames.csv, odom.csv and
// imu.csv parsers (each wants its own header line, so one corpus serves all three; wheels.csv has
// its own reader and target, wheel_encoders_fuzz). Each must either return finite rows with
// strictly increasing stamps or throw plumb::Error.
// Seeds: fuzz/seeds/frame_dump_csv/*.csv.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "plumb/core/error.hpp"
#include "plumb/io/frame_dump.hpp"

#include "fuzz_require.hpp"

// Names this target in the messages of FUZZ_REQUIRE.
constexpr const char* kFuzzTarget = "frame_dump_csv_fuzz";

namespace {

template <class Rows>
void check_stamps(const Rows& rows) {
  for (std::size_t i = 0; i < rows.size(); ++i) {
    FUZZ_REQUIRE(std::isfinite(rows[i].stamp));
    FUZZ_REQUIRE(i == 0 || rows[i].stamp > rows[i - 1].stamp);
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const plumb::io::FrameDumpIndex index = plumb::io::parse_frame_dump_frames(text, "fuzz/frames.csv");
    FUZZ_REQUIRE(index.stamps.size() == index.files.size());
    for (std::size_t i = 0; i < index.stamps.size(); ++i) {
      FUZZ_REQUIRE(std::isfinite(index.stamps[i]) && !index.files[i].empty());
      FUZZ_REQUIRE(i == 0 || index.stamps[i] > index.stamps[i - 1]);
    }
  } catch (const plumb::Error&) {
  }
  try {
    const std::vector<plumb::io::OdomSample> odom = plumb::io::parse_frame_dump_odometry(text, "fuzz/odom.csv");
    check_stamps(odom);
    for (const auto& o : odom) FUZZ_REQUIRE(std::isfinite(o.pose.x) && std::isfinite(o.pose.y) && std::isfinite(o.pose.theta));
  } catch (const plumb::Error&) {
  }
  try {
    const std::vector<plumb::io::ImuSample> imu = plumb::io::parse_frame_dump_imu(text, "fuzz/imu.csv");
    check_stamps(imu);
    for (const auto& m : imu) FUZZ_REQUIRE(m.gyro.allFinite() && m.accel.allFinite());
  } catch (const plumb::Error&) {
  }
  return 0;
}
