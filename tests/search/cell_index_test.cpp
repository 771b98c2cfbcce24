// SPDX-License-Identifier: BSD-3-Clause
// CellIndex against a scan of every point: the points in a box, the cells, a stray point far away,
// non-finite points and bad settings.

#include "plumb/search/cell_index.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

#include "plumb/core/error.hpp"

namespace {

using plumb::CellIndex;
using plumb::Vector3d;
using plumb::Vector3f;

/// Points of two dense blobs and a uniform spread, a few of them NaN or infinite.
std::vector<Vector3f> blob_cloud(std::mt19937& rng) {
  std::normal_distribution<float> blob(0.0f, 0.7f);
  std::uniform_real_distribution<float> spread(-10.0f, 10.0f);
  std::vector<Vector3f> p;
  for (int i = 0; i < 3000; ++i) p.emplace_back(blob(rng) + 2.0f, blob(rng) - 3.0f, blob(rng));
  for (int i = 0; i < 3000; ++i) p.emplace_back(spread(rng), spread(rng), 0.3f * spread(rng));
  p[17] = Vector3f(std::numeric_limits<float>::quiet_NaN(), 0.0f, 0.0f);
  p[4000] = Vector3f(0.0f, std::numeric_limits<float>::infinity(), 0.0f);
  return p;
}

std::vector<std::uint32_t> scanned(const std::vector<Vector3f>& p, const Eigen::AlignedBox3d& box) {
  std::vector<std::uint32_t> out;
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (p[i].allFinite() && box.contains(p[i].cast<double>())) out.push_back(static_cast<std::uint32_t>(i));
  }
  return out;
}

void expect_boxes_match_a_scan(const std::vector<Vector3f>& p, const CellIndex& index, std::mt19937& rng) {
  std::uniform_real_distribution<double> corner(-12.0, 12.0), size(0.0, 9.0);
  std::vector<std::uint32_t> got;
  for (int k = 0; k < 200; ++k) {
    const Vector3d lo(corner(rng), corner(rng), corner(rng));
    const Eigen::AlignedBox3d box(lo, lo + Vector3d(size(rng), size(rng), size(rng)));
    index.points_in_box(p, box, got);
    ASSERT_EQ(got, scanned(p, box)) << "box " << k;
  }
  // A box around everything, one beyond it, and a box that is a single point of the cloud.
  const double inf = std::numeric_limits<double>::infinity();
  index.points_in_box(p, Eigen::AlignedBox3d(Vector3d::Constant(-inf), Vector3d::Constant(inf)), got);
  EXPECT_EQ(got.size(), index.size());
  index.points_in_box(p, Eigen::AlignedBox3d(Vector3d::Constant(1e4), Vector3d::Constant(1e4 + 1)), got);
  EXPECT_TRUE(got.empty());
  const Vector3d q = p[5].cast<double>();
  index.points_in_box(p, Eigen::AlignedBox3d(q, q), got);
  EXPECT_EQ(got, scanned(p, Eigen::AlignedBox3d(q, q)));
  ASSERT_FALSE(got.empty());
}

TEST(CellIndexTest, PointsInABoxAreThoseAScanFinds) {
  std::mt19937 rng(3);
  const std::vector<Vector3f> p = blob_cloud(rng);
  const CellIndex index(p, 1.5);
  EXPECT_EQ(index.size(), p.size() - 2);  // the NaN and the infinite point are left out
  EXPECT_EQ(index.cell_size(), 1.5);
  expect_boxes_match_a_scan(p, index, rng);
}

TEST(CellIndexTest, EveryPointLiesInItsCellAndEveryCellListsItsOwnAscending) {
  std::mt19937 rng(4);
  const std::vector<Vector3f> p = blob_cloud(rng);
  const CellIndex index(p, 2.0);
  std::size_t listed = 0;
  for (std::size_t c = 0; c < index.num_cells(); ++c) {
    Eigen::AlignedBox3d box = index.cell_box(c);
    box.min().array() -= 1e-5;
    box.max().array() += 1e-5;
    for (const std::uint32_t* it = index.cell_begin(c); it != index.cell_end(c); ++it, ++listed) {
      ASSERT_EQ(index.cell(p[*it]), c);
      ASSERT_TRUE(box.contains(p[*it].cast<double>())) << *it;
      if (it != index.cell_begin(c)) {
        ASSERT_LT(*(it - 1), *it);
      }
    }
  }
  EXPECT_EQ(listed, index.size());
}

TEST(CellIndexTest, AStrayPointFarAwayCoarsensTheGridInsteadOfGrowingIt) {
  std::mt19937 rng(5);
  std::vector<Vector3f> p = blob_cloud(rng);
  p.emplace_back(1e6f, -1e6f, 5e5f);
  const CellIndex index(p, 0.5, 4096);
  EXPECT_LE(index.num_cells(), 4096u);
  EXPECT_GT(index.cell_size(), 0.5);
  expect_boxes_match_a_scan(p, index, rng);
}

TEST(CellIndexTest, EmptyAndBadInput) {
  const std::vector<Vector3f> none;
  const CellIndex empty(none, 1.0);
  std::vector<std::uint32_t> got{1, 2};
  empty.points_in_box(none, Eigen::AlignedBox3d(Vector3d::Constant(-1), Vector3d::Constant(1)), got);
  EXPECT_TRUE(got.empty());
  EXPECT_EQ(empty.size(), 0u);
  const std::vector<Vector3f> one{Vector3f(1, 2, 3)};
  EXPECT_THROW(CellIndex(one, 0.0), plumb::Error);
  EXPECT_THROW(CellIndex(one, -1.0), plumb::Error);
  EXPECT_THROW(CellIndex(one, std::numeric_limits<double>::quiet_NaN()), plumb::Error);
  EXPECT_THROW(CellIndex(one, 1.0, 0), plumb::Error);
}

}  // namespace
