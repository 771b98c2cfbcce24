// SPDX-License-Identifier: BSD-3-Clause
// The parallel layer: every chunk runs exactly once on any thread count, outputs come back in item
// order (the same as one sequential pass), a floating-point sum over chunk partials is the same bit
// for bit on 1..16 threads, and errors are reported as the lowest failing chunk's whatever the count.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <future>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "plumb/core/error.hpp"
#include "plumb/core/parallel.hpp"
#include "plumb/core/rng.hpp"

namespace plumb {
namespace {

TEST(ParallelTest, ResolvesThreadCounts) {
  EXPECT_EQ(resolve_thread_count(1), 1);
  EXPECT_EQ(resolve_thread_count(7), 7);
  EXPECT_EQ(resolve_thread_count(0), static_cast<int>(std::max(1u, std::thread::hardware_concurrency())));
  EXPECT_THROW(resolve_thread_count(-1), Error);
  EXPECT_EQ(chunk_count(0, 8), 0u);
  EXPECT_EQ(chunk_count(8, 8), 1u);
  EXPECT_EQ(chunk_count(9, 8), 2u);
}

TEST(ParallelTest, EveryChunkRunsOnce) {
  for (int threads : {1, 2, 3, 8, 0}) {
    const std::size_t chunks = 101;
    std::vector<std::atomic<int>> runs(chunks);
    parallel_chunks(threads, chunks, [&](std::size_t c) { runs[c].fetch_add(1); });
    for (std::size_t c = 0; c < chunks; ++c) EXPECT_EQ(runs[c].load(), 1) << "chunk " << c << ", threads " << threads;
  }
  bool called = false;
  parallel_chunks(4, 0, [&](std::size_t) { called = true; });
  EXPECT_FALSE(called);
}

TEST(ParallelTest, UsesSeveralThreadsWhenAsked) {
  // Each chunk waits until two chunks are running at once (or gives up after a while): with two
  // threads, some chunk sees the other.
  std::atomic<int> running{0}, peak{0};
  parallel_chunks(2, 8, [&](std::size_t) {
    const int now = running.fetch_add(1) + 1;
    int seen = peak.load();
    while (now > seen && !peak.compare_exchange_weak(seen, now)) {
    }
    for (int i = 0; i < 2000 && running.load() < 2; ++i) std::this_thread::sleep_for(std::chrono::microseconds(50));
    running.fetch_sub(1);
  });
  EXPECT_EQ(peak.load(), 2);
}

TEST(ParallelTest, NestedAndConcurrentCallsEachRunEveryChunkOnce) {
  // Worker threads outlive the calls and are shared: calls made from inside a chunk, and calls made
  // at once from several threads, must each finish with every chunk run once, whatever the workers
  // are busy with.
  constexpr std::size_t kOuter = 24, kInner = 17;
  auto nested = [&](int threads) {
    std::vector<std::atomic<int>> runs(kOuter * kInner);
    parallel_chunks(threads, kOuter, [&](std::size_t c) {
      parallel_chunks(threads, kInner, [&](std::size_t i) { runs[c * kInner + i].fetch_add(1); });
    });
    int wrong = 0;
    for (const std::atomic<int>& r : runs) wrong += r.load() == 1 ? 0 : 1;
    return wrong;
  };
  for (int threads : {2, 3, 8}) {
    std::vector<std::future<int>> callers;
    for (int k = 0; k < 4; ++k) callers.push_back(std::async(std::launch::async, nested, threads));
    for (std::future<int>& f : callers) EXPECT_EQ(f.get(), 0) << "threads " << threads;
  }
}

TEST(ParallelTest, AppendKeepsItemOrderForAnyThreadCount) {
  // Item i appends i % 3 copies of i: the expected sequence is built by a plain loop.
  const std::size_t n = 10007;
  std::vector<std::size_t> expected{42};
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t k = 0; k < i % 3; ++k) expected.push_back(i);
  }
  for (int threads : {1, 2, 3, 5, 16}) {
    for (std::size_t grain : {1, 7, 256, 20000}) {
      std::vector<std::size_t> out{42};
      parallel_append(threads, n, grain, out, [](std::size_t b, std::size_t e, std::vector<std::size_t>& o) {
        for (std::size_t i = b; i < e; ++i) {
          for (std::size_t k = 0; k < i % 3; ++k) o.push_back(i);
        }
      });
      EXPECT_EQ(out, expected) << "threads " << threads << ", grain " << grain;
    }
  }
}

TEST(ParallelTest, ChunkPartialSumsAreBitIdenticalAcrossThreadCounts) {
  // Values spanning many magnitudes make the sum depend on its order; the fixed partition and the
  // in-order reduction of the partials give the same bits on every thread count.
  Rng rng(7);
  std::vector<double> v(50000);
  for (double& x : v) x = rng.normal() * std::pow(10.0, rng.uniform(-8.0, 8.0));
  const std::size_t grain = 512;
  auto sum = [&](int threads) {
    std::vector<double> partial(chunk_count(v.size(), grain), 0.0);
    parallel_for(threads, v.size(), grain, [&](std::size_t b, std::size_t e) {
      double s = 0.0;
      for (std::size_t i = b; i < e; ++i) s += v[i];
      partial[b / grain] = s;
    });
    double total = 0.0;
    for (double p : partial) total += p;
    return total;
  };
  const double one = sum(1);
  for (int threads : {2, 3, 4, 8, 16}) EXPECT_EQ(sum(threads), one) << "threads " << threads;
}

TEST(ParallelTest, RethrowsTheLowestFailingChunk) {
  for (int threads : {1, 2, 4}) {
    std::atomic<int> ran{0};
    try {
      parallel_chunks(threads, 40, [&](std::size_t c) {
        ran.fetch_add(1);
        if (c == 13 || c == 31) throw std::runtime_error("chunk " + std::to_string(c));
      });
      ADD_FAILURE() << "no exception, threads " << threads;
    } catch (const std::runtime_error& e) {
      EXPECT_STREQ(e.what(), "chunk 13") << "threads " << threads;
    }
    EXPECT_GE(ran.load(), 14) << "threads " << threads;  // every chunk up to the failing one
  }
}

TEST(ParallelTest, StartBesideRunsOnASecondThreadOrOnTheCallersAtGet) {
  const std::thread::id caller = std::this_thread::get_id();
  for (int threads : {2, 0}) {
    std::future<std::thread::id> f = start_beside(threads, [] { return std::this_thread::get_id(); });
    EXPECT_NE(f.get(), caller) << "threads " << threads;
  }
  std::atomic<int> runs{0};
  std::future<std::thread::id> f = start_beside(1, [&runs] {
    runs.fetch_add(1);
    return std::this_thread::get_id();
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(2));
  EXPECT_EQ(runs.load(), 0);  // deferred: nothing runs until get()
  EXPECT_EQ(f.get(), caller);
  EXPECT_EQ(runs.load(), 1);
  {
    std::future<std::thread::id> never = start_beside(1, [&runs] {
      runs.fetch_add(1);
      return std::this_thread::get_id();
    });
  }
  EXPECT_EQ(runs.load(), 1);  // a deferred call whose result is never asked for never runs
  // An exception arrives at get(), on any thread count.
  for (int threads : {1, 2}) {
    std::future<int> g = start_beside(threads, []() -> int { throw std::runtime_error("beside"); });
    try {
      g.get();
      ADD_FAILURE() << "no exception, threads " << threads;
    } catch (const std::runtime_error& e) {
      EXPECT_STREQ(e.what(), "beside");
    }
  }
}

}  // namespace
}  // namespace plumb
