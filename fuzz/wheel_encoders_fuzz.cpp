// SPDX-License-Identifier: BSD-3-Clause
// libFuzzer target: parse_wheel_encoders (wheels.csv; angles, and ticks when the first byte is odd)
// must either return finite readings with strictly increasing stamps or throw plumb::Error.
// Seeds: fuzz/seeds/wheel_encoders/*.csv.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "plumb/core/error.hpp"
#include "plumb/io/wheel_encoders.hpp"

#include "fuzz_require.hpp"

// Names this target in the messages of FUZZ_REQUIRE.
constexpr const char* kFuzzTarget = "wheel_encoders_fuzz";

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  plumb::io::WheelEncoderReadSettings settings;
  // Tick counts are scaled by 2 pi / ticks_per_revolution; with one tick per revolution the
  // largest finite counts overflow to infinity, which the reader must reject.
  if (size > 0 && (data[0] & 1u) != 0) settings.ticks_per_revolution = 1.0;
  try {
    const std::vector<plumb::WheelEncoderReading> readings =
        plumb::io::parse_wheel_encoders(text, "fuzz.csv", settings);
    FUZZ_REQUIRE(!readings.empty());
    for (std::size_t i = 0; i < readings.size(); ++i) {
      FUZZ_REQUIRE(std::isfinite(readings[i].stamp));
      FUZZ_REQUIRE(std::isfinite(readings[i].left) && std::isfinite(readings[i].right));
      FUZZ_REQUIRE(i == 0 || readings[i].stamp > readings[i - 1].stamp);
    }
  } catch (const plumb::Error&) {
  }
  return 0;
}
