// SPDX-License-Identifier: BSD-3-Clause
// libFuzzer target: read_pcd_buffer must either return a consistent cloud or throw plumb::Error.
#include <cstddef>
#include <cstdint>

#include "plumb/core/error.hpp"
#include "plumb/io/pcd.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    const plumb::PointCloud cloud =
        plumb::io::read_pcd_buffer(reinterpret_cast<const char*>(data), size, "fuzz.pcd");
    cloud.check_consistent("pcd_fuzz");
  } catch (const plumb::Error&) {
  }
  return 0;
}
