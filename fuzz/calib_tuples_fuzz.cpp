// SPDX-License-Identifier: BSD-3-Clause
// libFuzzer target: parse_calib_tuples (Censi's JSON-lines tuple files) must either return
// finite tuples with T > 0 or throw plumb::Error.
// Seeds: $PLUMB_DATA_DIR/laser2d/calibration_censi (scripts/test.sh) and fuzz/seeds/calib_tuples.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "plumb/core/error.hpp"
#include "plumb/io/calib_tuples.hpp"

#include "fuzz_require.hpp"

// Names this target in the messages of FUZZ_REQUIRE.
constexpr const char* kFuzzTarget = "calib_tuples_fuzz";

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const std::vector<plumb::CalibrationTuple> tuples = plumb::io::parse_calib_tuples(text, "fuzz.tuple");
    FUZZ_REQUIRE(!tuples.empty());
    for (const plumb::CalibrationTuple& t : tuples) {
      FUZZ_REQUIRE(std::isfinite(t.T) && t.T > 0.0);
      FUZZ_REQUIRE(std::isfinite(t.phi_left) && std::isfinite(t.phi_right));
      FUZZ_REQUIRE(std::isfinite(t.laser_motion.x) && std::isfinite(t.laser_motion.y) &&
                   std::isfinite(t.laser_motion.theta));
    }
  } catch (const plumb::Error&) {
  }
  return 0;
}
