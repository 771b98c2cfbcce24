// SPDX-License-Identifier: BSD-3-Clause
// keep_freed_memory(): after it, the buffers of one "frame" (made on a second thread, freed on the
// caller's, as the frame readers ahead of the estimators do) are served from memory freed by the
// frames before, so the pages are not faulted in again every frame.
#include "plumb/core/allocator.hpp"

#include <sys/resource.h>

#include <cstddef>
#include <future>
#include <vector>

#include <gtest/gtest.h>

#if defined(__SANITIZE_ADDRESS__)
#define PLUMB_TEST_UNDER_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define PLUMB_TEST_UNDER_ASAN 1
#endif
#endif

namespace plumb {
namespace {

long minor_faults() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_minflt;
}

TEST(AllocatorTest, FramesReuseTheMemoryOfTheFramesBefore) {
#if !defined(__GLIBC__)
  GTEST_SKIP() << "keep_freed_memory() applies to glibc only";
#elif defined(PLUMB_TEST_UNDER_ASAN)
  GTEST_SKIP() << "the address sanitizer's allocator replaces glibc's";
#endif
  ASSERT_TRUE(keep_freed_memory());
  // One frame: a ~1.1 MiB byte buffer made on another thread and a ~1.2 MiB float array, both
  // touched in full and freed; sizes vary a little from frame to frame, as real frames do.
  auto frame = [](int i) {
    auto made = std::async(std::launch::async, [i] {
      return std::vector<char>((std::size_t{1} << 20) + static_cast<std::size_t>(i % 3) * 100000, 1);
    });
    std::vector<char> bytes = made.get();
    std::vector<float> decoded(300000 + static_cast<std::size_t>(i) * 1000, 2.f);
    return bytes.size() + decoded.size() * sizeof(float);
  };
  const std::size_t frame_bytes = frame(0) + frame(1);  // warm-up
  const long before = minor_faults();
  for (int i = 2; i < 42; ++i) frame(i);
  const long pages_per_frame = static_cast<long>(frame_bytes / 2 / 4096);
  // Forty frames touch ~40 * 580 pages; kept memory faults in only what a frame or two adds
  // (thread stacks and the arrays growing by 4 kB a frame included).
  EXPECT_LT(minor_faults() - before, 2 * pages_per_frame);
}

}  // namespace
}  // namespace plumb
