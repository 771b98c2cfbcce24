// SPDX-License-Identifier: BSD-3-Clause
// libFuzzer target for the CARMEN reader's file path: read_carmen_buffer (gzip with one or more
// members, or plain text) must either return a log or throw plumb::Error. The text parser itself
// is fuzzed by carmen_fuzz; this target is about the gzip layer in front of it.
// Seeds: $PLUMB_DATA_DIR/laser2d/carmen_corrected (scripts/test.sh) and fuzz/seeds/carmen_gz.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>

#include "plumb/core/error.hpp"
#include "plumb/io/carmen.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    // A small inflate cap keeps each run short; the cap's own check is exercised on every input
    // that inflates past it.
    plumb::io::CarmenReadSettings settings;
    settings.max_inflated_bytes = std::size_t{64} << 20;
    const plumb::io::CarmenLog log =
        plumb::io::read_carmen_buffer(reinterpret_cast<const char*>(data), size, "fuzz.log.gz", settings);
    for (const plumb::io::CarmenLaser& laser : log.lasers) {
      laser.scan.check_consistent("carmen_gz_fuzz");
      if (laser.num_odometry_before > log.odometry.size()) {
        std::fprintf(stderr, "carmen_gz_fuzz: laser at line %zu counts %zu odometry messages before it of %zu\n",
                     laser.line, laser.num_odometry_before, log.odometry.size());
        std::abort();
      }
    }
  } catch (const plumb::Error&) {
  }
  return 0;
}
