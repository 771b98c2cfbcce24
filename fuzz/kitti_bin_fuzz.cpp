// SPDX-License-Identifier: BSD-3-Clause
// libFuzzer target: read_kitti_bin_buffer must either return a consistent cloud of size / 16
// points with intensities or throw plumb::Error.
// Seeds: fuzz/seeds/kitti_bin/*.bin.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>

#include "plumb/core/error.hpp"
#include "plumb/io/kitti_bin.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    const plumb::PointCloud cloud =
        plumb::io::read_kitti_bin_buffer(reinterpret_cast<const char*>(data), size, "fuzz.bin");
    cloud.check_consistent("kitti_bin_fuzz");
    if (cloud.size() != size / 16 || size % 16 != 0 || cloud.intensities.size() != cloud.size()) {
      std::fprintf(stderr, "kitti_bin_fuzz: %zu points from %zu bytes\n", cloud.size(), size);
      std::abort();
    }
  } catch (const plumb::Error&) {
  }
  return 0;
}
