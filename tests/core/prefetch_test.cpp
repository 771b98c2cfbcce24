// SPDX-License-Identifier: BSD-3-Clause
// The prefetch stage gives the items of the serial loop in order, makes them on a thread of its own
// up to `depth` ahead of the consumer and never more, calls make() in index order and never twice at
// once (a stage may keep state), and rethrows an item's error where the serial loop meets it.
#include <atomic>
#include <chrono>
#include <cstddef>
#include <stdexcept>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "plumb/core/prefetch.hpp"

namespace plumb {
namespace {

// Waits (polling, up to 20 s: a loaded machine may take long to run the stage's thread) until
// `count` reaches `at_least`; returns the count seen.
int wait_for_count(const std::atomic<int>& count, int at_least) {
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (count.load() < at_least && std::chrono::steady_clock::now() < until) {
    std::this_thread::sleep_for(std::chrono::microseconds(50));
  }
  return count.load();
}

TEST(PrefetchTest, GivesTheSerialItemsAndMakesTheNextOneAhead) {
  constexpr std::size_t kItems = 20;
  for (int threads : {1, 2, 0}) {
    std::vector<std::atomic<int>> made(kItems);
    std::size_t ahead = 0;  // items whose successor began while the consumer held them
    {
      Prefetch<std::vector<int>> items(threads, kItems, [&](std::size_t i) {
        made[i].fetch_add(1);
        return std::vector<int>(i + 1, static_cast<int>(i));
      });
      for (std::size_t i = 0; i < kItems; ++i) {
        const std::vector<int> item = items.get(i);
        ASSERT_EQ(item, std::vector<int>(i + 1, static_cast<int>(i))) << "threads " << threads;
        if (i + 1 == kItems) continue;
        // With a thread, item i + 1 is begun while this one is held: wait for it. On one thread it
        // is made only when asked for, so it must not begin however long this item is held.
        if (threads == 1) {
          std::this_thread::sleep_for(std::chrono::milliseconds(2));
        } else {
          wait_for_count(made[i + 1], 1);
        }
        ahead += made[i + 1].load() > 0 ? 1 : 0;
      }
    }
    for (std::size_t i = 0; i < kItems; ++i) EXPECT_EQ(made[i].load(), 1) << "item " << i << ", threads " << threads;
    EXPECT_EQ(ahead, threads == 1 ? 0u : kItems - 1) << "threads " << threads;
  }
}

TEST(PrefetchTest, MakesUpToDepthItemsAheadInOrderOneAtATime) {
  constexpr std::size_t kItems = 30;
  for (std::size_t depth : {1u, 2u, 4u}) {
    std::atomic<int> made{0};    // items made so far
    std::atomic<int> inside{0};  // make() calls running now
    std::atomic<bool> overlapped{false};
    std::vector<std::size_t> order;  // written by make() alone: it never runs twice at once
    {
      Prefetch<std::size_t> items(
          2, kItems,
          [&](std::size_t i) {
            if (inside.fetch_add(1) != 0) overlapped = true;
            order.push_back(i);
            std::this_thread::sleep_for(std::chrono::microseconds(200));
            inside.fetch_sub(1);
            made.fetch_add(1);
            return i * 7;
          },
          depth);
      for (std::size_t i = 0; i < kItems; ++i) {
        // Before item i is taken, items i .. i + depth - 1 are made (the stage's thread works while
        // the consumer holds item i - 1) and no more: the stage waits for the consumer.
        const int expected = static_cast<int>(std::min(kItems, i + depth));
        EXPECT_EQ(wait_for_count(made, expected), expected) << "depth " << depth << ", before item " << i;
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
        EXPECT_EQ(made.load(), expected) << "depth " << depth << ", before item " << i;
        EXPECT_EQ(items.get(i), i * 7);
      }
    }
    EXPECT_FALSE(overlapped.load()) << "depth " << depth;
    ASSERT_EQ(order.size(), kItems) << "depth " << depth;
    for (std::size_t i = 0; i < kItems; ++i) EXPECT_EQ(order[i], i) << "depth " << depth;
  }
}

TEST(PrefetchTest, RethrowsAnItemsErrorWhereTheSerialLoopMeetsIt) {
  for (int threads : {1, 2}) {
    for (std::size_t depth : {1u, 3u}) {
      std::size_t got = 0;
      std::atomic<int> after_error{0};  // items after the failing one that were made
      try {
        Prefetch<int> items(
            threads, 10,
            [&after_error](std::size_t i) -> int {
              if (i == 4) throw std::runtime_error("item 4");
              if (i > 4) after_error.fetch_add(1);
              return static_cast<int>(i);
            },
            depth);
        for (std::size_t i = 0; i < 10; ++i) {
          EXPECT_EQ(items.get(i), static_cast<int>(i));
          ++got;
        }
        ADD_FAILURE() << "no exception, threads " << threads;
      } catch (const std::runtime_error& e) {
        EXPECT_STREQ(e.what(), "item 4");
      }
      EXPECT_EQ(got, 4u) << "threads " << threads << ", depth " << depth;  // items 0-3 came before the error
      EXPECT_EQ(after_error.load(), 0) << "threads " << threads << ", depth " << depth;
    }
  }
}

TEST(PrefetchTest, AskingOutOfOrderDropsWhatWasMadeAheadAndGoesOnFromThere) {
  for (int threads : {1, 2}) {
    std::vector<std::atomic<int>> made(10);
    {
      Prefetch<int> items(
          threads, 10,
          [&made](std::size_t i) {
            made[i].fetch_add(1);
            return static_cast<int>(i) * 3;
          },
          2);
      EXPECT_EQ(items.get(0), 0);
      EXPECT_EQ(items.get(5), 15);
      EXPECT_EQ(items.get(6), 18);
      // Each item asked for was made once; of the items after 0, at most the two within the depth
      // were made ahead (and dropped), none beyond them; on one thread nothing that was not asked for.
      for (std::size_t i : {0u, 5u, 6u}) EXPECT_EQ(made[i].load(), 1) << "item " << i << ", threads " << threads;
      for (std::size_t i : {1u, 2u}) EXPECT_LE(made[i].load(), threads == 1 ? 0 : 1) << "item " << i;
      for (std::size_t i : {3u, 4u}) EXPECT_EQ(made[i].load(), 0) << "item " << i << ", threads " << threads;
      EXPECT_EQ(items.get(2), 6);  // back again
      EXPECT_EQ(items.get(3), 9);
      EXPECT_THROW(items.get(10), std::out_of_range);
    }
    EXPECT_EQ(made[9].load(), 0) << "threads " << threads;
  }
}

}  // namespace
}  // namespace plumb
