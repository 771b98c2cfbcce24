// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/io/stamps.hpp"

#include <vector>

#include <gtest/gtest.h>

namespace plumb::io {
namespace {

TEST(OrderStampsTest, IncreasingStampsAreKeptAsTheyAre) {
  const std::vector<double> t = {0.0, 0.1, 0.25, 0.3};
  const StampOrder o = order_stamps(t);
  EXPECT_EQ(o.kept, (std::vector<std::size_t>{0, 1, 2, 3}));
  EXPECT_EQ(o.stamps, t);
  EXPECT_TRUE(o.dropped.empty());
  EXPECT_EQ(o.respread, 0u);
  EXPECT_TRUE(order_stamps({}).kept.empty());
}

// A clock stepped back: the records before the step's level are dropped, the rest carry on.
TEST(OrderStampsTest, RecordsGoingBackInTimeAreDropped) {
  const StampOrder o = order_stamps({1.0, 2.0, 1.5, 1.9, 2.5, 3.0});
  EXPECT_EQ(o.kept, (std::vector<std::size_t>{0, 1, 4, 5}));
  EXPECT_EQ(o.dropped, (std::vector<std::size_t>{2, 3}));
  EXPECT_EQ(o.stamps, (std::vector<double>{1.0, 2.0, 2.5, 3.0}));
}

// A quantised clock: every record is kept in message order, a run of k records sharing a stamp
// spread over the interval to the next stamp in steps of 1/k of it; the last run, with nothing
// after it, takes the median spacing of the runs before.
TEST(OrderStampsTest, SharedStampsAreSpreadToTheNextOne) {
  const StampOrder o = order_stamps({10.0, 10.0, 10.0, 10.0, 20.0, 20.0, 30.0, 30.0, 30.0});
  EXPECT_EQ(o.kept.size(), 9u);
  EXPECT_TRUE(o.dropped.empty());
  EXPECT_EQ(o.respread, 1u + 2u + 3u);
  // The interior runs are spaced 2.5 and 5.0; the last takes their (upper) median, 5.0.
  const std::vector<double> expected = {10.0, 12.5, 15.0, 17.5, 20.0, 25.0, 30.0};
  ASSERT_EQ(o.stamps.size(), 9u);
  for (std::size_t k = 0; k < expected.size(); ++k) EXPECT_DOUBLE_EQ(o.stamps[k], expected[k]) << k;
  EXPECT_DOUBLE_EQ(o.stamps[7], 35.0);
  EXPECT_DOUBLE_EQ(o.stamps[8], 40.0);
  for (std::size_t k = 1; k < o.stamps.size(); ++k) EXPECT_GT(o.stamps[k], o.stamps[k - 1]);
  // Ties and a step back together; nothing after the only run: 1 ms apart.
  const StampOrder mixed = order_stamps({5.0, 5.0, 4.0, 5.0});
  EXPECT_EQ(mixed.kept, (std::vector<std::size_t>{0, 1, 3}));
  EXPECT_EQ(mixed.dropped, (std::vector<std::size_t>{2}));
  EXPECT_DOUBLE_EQ(mixed.stamps[1], 5.001);
  EXPECT_DOUBLE_EQ(mixed.stamps[2], 5.002);
}

}  // namespace
}  // namespace plumb::io
