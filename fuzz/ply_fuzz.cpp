// SPDX-License-Identifier: BSD-3-Clause
// libFuzzer target: read_ply_buffer must either return a consistent cloud or throw plumb::Error.
#include <cstddef>
#include <cstdint>

#include "plumb/core/error.hpp"
#include "plumb/io/ply.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    const plumb::PointCloud cloud =
        plumb::io::read_ply_buffer(reinterpret_cast<const char*>(data), size, "fuzz.ply");
    cloud.check_consistent("ply_fuzz");
  } catch (const plumb::Error&) {
  }
  return 0;
}
