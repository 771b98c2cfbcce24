// SPDX-License-Identifier: BSD-3-Clause
// KdTree against the BruteForceSearch oracle, edge cases, bad input, threads and real data.

#include "plumb/search/kdtree.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <thread>
#include <tuple>
#include <vector>

#include "plumb/core/error.hpp"
#include "plumb/core/point_cloud.hpp"
#include "plumb/core/rng.hpp"
#include "plumb/search/brute_force.hpp"
#include "kdtree_oracle.hpp"
#include "test_data.hpp"

#if __has_include("plumb/io/pcd.hpp")
#include "plumb/io/pcd.hpp"
#define PLUMB_TEST_HAVE_PCD 1
#endif

namespace {

using namespace plumb::kdtree_test;

template <int Dim>
void check_random_clouds() {
  const std::size_t sizes[] = {1, 2, 3, 9, 10, 11, 19, 20, 21, 100, 1000, 4000};
  const std::size_t leaf_sizes[] = {1, 2, 10, 20};
  std::uint64_t seed = 1;
  for (Shape shape : {Shape::kUniform, Shape::kClusters}) {
    for (std::size_t n : sizes) {
      const Points<Dim> pts = make_cloud<Dim>(n, shape, seed++);
      const BruteForceSearch<Dim> oracle(pts);
      std::vector<KdTree<Dim>> trees;
      std::vector<const KdTree<Dim>*> tree_ptrs;
      for (std::size_t leaf : leaf_sizes) {
        for (auto split : {plumb::KdTreeSplit::kMean, plumb::KdTreeSplit::kMidpoint}) {
          trees.emplace_back(pts, KdTreeSettings{leaf, split});
        }
      }
      for (const auto& tree : trees) {
        ASSERT_EQ(tree.size(), n);
        tree_ptrs.push_back(&tree);
      }
      plumb::Rng rng(seed * 7919);
      const std::string what = "Dim=" + std::to_string(Dim) + " n=" + std::to_string(n) +
                               (shape == Shape::kUniform ? " uniform" : " clusters");
      const int num_queries = n >= 1000 ? 16 : 12;
      for (int qi = 0; qi < num_queries; ++qi) {
        // Half the queries on data points (exact hits, ties with duplicates), half random.
        const auto q = qi % 2 == 0 ? pts[rng.uniform_index(n)] : random_query<Dim>(rng, 14.0);
        for (std::size_t k : {std::size_t{1}, std::size_t{5}, std::size_t{10}, n + 3}) {
          expect_knn_equal(tree_ptrs, oracle, pts, q, k, what);
          for (float b : {0.0f, 0.09f, 4.0f, kInf}) expect_bounded_knn_equal(tree_ptrs, oracle, pts, q, k, b, what);
        }
        for (float r : {0.0f, 0.3f, 2.0f}) expect_radius_equal(tree_ptrs, oracle, q, r, what);
        expect_nearest_equal(tree_ptrs, oracle, q, kInf, what);
        expect_nearest_equal(tree_ptrs, oracle, q, 0.05f, what);
      }
    }
  }
}

TEST(KdTreeTest, KnnRadiusNearestMatchBruteForce2D) { check_random_clouds<2>(); }
TEST(KdTreeTest, KnnRadiusNearestMatchBruteForce3D) { check_random_clouds<3>(); }

TEST(KdTreeTest, BuildsFromPointCloudWithOriginalIndices) {
  plumb::PointCloud cloud;
  cloud.points = make_cloud<3>(500, Shape::kClusters, 99);
  const plumb::KdTree3f tree(cloud);
  for (std::size_t i = 0; i < cloud.size(); i += 37) {
    const auto nb = tree.nearest(cloud.points[i]);
    ASSERT_TRUE(nb.has_value());
    EXPECT_EQ(nb->dist_sq, 0.0f);
    EXPECT_EQ(cloud.points[nb->index], cloud.points[i]);
  }
}

TEST(KdTreeTest, DuplicatesAreAllReturned) {
  Points<3> base = make_cloud<3>(200, Shape::kUniform, 5);
  Points<3> pts;
  for (int rep = 0; rep < 7; ++rep) pts.insert(pts.end(), base.begin(), base.end());
  const plumb::KdTree3f tree(pts, KdTreeSettings{4});
  const plumb::BruteForceSearch3f oracle(pts);
  for (std::size_t i = 0; i < base.size(); i += 13) {
    // The 7 copies of base[i] are the 7 nearest, all at distance 0.
    std::vector<std::size_t> idx;
    std::vector<float> d;
    ASSERT_EQ(tree.knn(base[i], 7, idx, d), 7u);
    std::set<std::size_t> got(idx.begin(), idx.end());
    std::set<std::size_t> want;
    for (std::size_t rep = 0; rep < 7; ++rep) want.insert(rep * base.size() + i);
    EXPECT_EQ(got, want);
    for (float x : d) EXPECT_EQ(x, 0.0f);
    expect_knn_equal(tree, oracle, pts, base[i], 10, "duplicates");
    EXPECT_EQ(tree.radius(base[i], 0.0f).size(), 7u);
  }
}

TEST(KdTreeTest, AllPointsEqual) {
  const Points<3> pts(1000, Eigen::Vector3f(1.5f, -2.0f, 0.25f));
  const plumb::KdTree3f tree(pts);
  EXPECT_EQ(tree.num_nodes(), 1u);  // a bucket of coincident points is never split
  const auto nn = tree.knn(Eigen::Vector3f(1.5f, -2.0f, 1.25f), 5);
  ASSERT_EQ(nn.size(), 5u);
  for (const Neighbor& n : nn) EXPECT_EQ(n.dist_sq, 1.0f);
  EXPECT_EQ(tree.radius(pts[0], 0.0f).size(), 1000u);
  EXPECT_EQ(tree.radius(Eigen::Vector3f(0, 0, 0), 0.5f).size(), 0u);
  EXPECT_EQ(tree.knn(pts[0], 5000).size(), 1000u);
}

TEST(KdTreeTest, CollinearPoints) {
  Points<3> pts;
  for (int i = 0; i < 600; ++i) {
    const float t = 0.01f * static_cast<float>(i);
    pts.emplace_back(t, 0.0f, 0.0f);           // along x
    pts.emplace_back(1.0f + t, 2.0f + t, -t);  // a diagonal
  }
  const plumb::KdTree3f tree(pts, KdTreeSettings{3});
  const plumb::BruteForceSearch3f oracle(pts);
  plumb::Rng rng(3);
  for (int i = 0; i < 100; ++i) {
    const Eigen::Vector3f q = random_query<3>(rng, 8.0);
    expect_knn_equal(tree, oracle, pts, q, 4, "collinear");
    expect_radius_equal(tree, oracle, q, 1.0f, "collinear");
  }
}

TEST(KdTreeTest, KOneEqualsNearestAndKAboveSizeReturnsAllSorted) {
  const Points<2> pts = make_cloud<2>(300, Shape::kUniform, 11);
  const plumb::KdTree2f tree(pts);
  plumb::Rng rng(12);
  for (int i = 0; i < 50; ++i) {
    const Eigen::Vector2f q = random_query<2>(rng, 12.0);
    const auto one = tree.knn(q, 1);
    const auto nb = tree.nearest(q);
    ASSERT_EQ(one.size(), 1u);
    ASSERT_TRUE(nb.has_value());
    EXPECT_EQ(one[0].dist_sq, nb->dist_sq);
    const auto all = tree.knn(q, 1000);
    ASSERT_EQ(all.size(), 300u);
    std::set<std::size_t> idx;
    for (std::size_t j = 0; j < all.size(); ++j) {
      idx.insert(all[j].index);
      if (j > 0) {
        EXPECT_LE(all[j - 1].dist_sq, all[j].dist_sq);
      }
    }
    EXPECT_EQ(idx.size(), 300u);
  }
  EXPECT_EQ(tree.knn(pts[0], 0).size(), 0u);
}

TEST(KdTreeTest, RadiusZeroAndHuge) {
  const Points<3> pts = make_cloud<3>(1000, Shape::kClusters, 21);
  const plumb::KdTree3f tree(pts);
  const auto hit = tree.radius(pts[17], 0.0f);
  ASSERT_GE(hit.size(), 1u);
  for (const Neighbor& n : hit) EXPECT_EQ(pts[n.index], pts[17]);
  EXPECT_EQ(tree.radius(Eigen::Vector3f(100.0f, 0.0f, 0.0f), 0.0f).size(), 0u);
  EXPECT_EQ(tree.radius(pts[3], 1e6f).size(), 1000u);
  EXPECT_EQ(tree.radius(pts[3], kInf).size(), 1000u);
  EXPECT_EQ(tree.radius(pts[3], -1.0f).size(), 0u);
  EXPECT_EQ(tree.radius(pts[3], kNaN).size(), 0u);
}

TEST(KdTreeTest, QueriesFarOutsideTheCloud) {
  const Points<3> pts = make_cloud<3>(2000, Shape::kUniform, 31);
  const plumb::KdTree3f tree(pts);
  const plumb::BruteForceSearch3f oracle(pts);
  for (const Eigen::Vector3f& q : {Eigen::Vector3f(1e5f, 0, 0), Eigen::Vector3f(-3e3f, 2e3f, 5e2f),
                                   Eigen::Vector3f(0, 0, -1e4f), Eigen::Vector3f(50, 50, 50)}) {
    expect_knn_equal(tree, oracle, pts, q, 8, "far");
    expect_nearest_equal(tree, oracle, q, kInf, "far");
    EXPECT_FALSE(tree.nearest(q, 1.0f).has_value());
    expect_radius_equal(tree, oracle, q, (q.norm() + 20.0f), "far");
  }
}

TEST(KdTreeTest, TiesGiveEqualDistanceSets) {
  // A grid: many points at exactly equal distances from grid-aligned queries.
  Points<2> pts;
  for (int x = -10; x <= 10; ++x) {
    for (int y = -10; y <= 10; ++y) pts.emplace_back(static_cast<float>(x), static_cast<float>(y));
  }
  const plumb::KdTree2f tree(pts, KdTreeSettings{5});
  const plumb::BruteForceSearch2f oracle(pts);
  for (const Eigen::Vector2f& q : {Eigen::Vector2f(0, 0), Eigen::Vector2f(0.5f, 0.5f),
                                   Eigen::Vector2f(3, -0.5f), Eigen::Vector2f(10.5f, 10.5f)}) {
    for (std::size_t k : {1, 2, 4, 5, 9, 13}) expect_knn_equal(tree, oracle, pts, q, k, "grid");
    expect_radius_equal(tree, oracle, q, 1.0f, "grid");
    expect_radius_equal(tree, oracle, q, 2.5f, "grid");
    // Bounds exactly at tie distances (0, 0.5, 1, 2.5 occur) count the points on them.
    for (float b : {-0.0f, 0.0f, 0.5f, 1.0f, 2.5f}) {
      for (std::size_t k : {1, 4, 9}) expect_bounded_knn_equal<2>({&tree}, oracle, pts, q, k, b, "grid");
    }
  }
  // The 4 nearest of a cell centre: exactly its 4 corners.
  const auto nn = tree.knn(Eigen::Vector2f(0.5f, 0.5f), 4);
  ASSERT_EQ(nn.size(), 4u);
  for (const Neighbor& n : nn) EXPECT_EQ(n.dist_sq, 0.5f);
}

TEST(KdTreeTest, EmptyOrAllNonFiniteInputThrows) {
  EXPECT_THROW(plumb::KdTree3f(Points<3>{}), plumb::Error);
  EXPECT_THROW(plumb::KdTree2f(Points<2>{}), plumb::Error);
  EXPECT_THROW(plumb::KdTree3f(plumb::PointCloud{}), plumb::Error);
  const Points<3> nan_only(10, Eigen::Vector3f(kNaN, 0, 0));
  EXPECT_THROW(plumb::KdTree3f{nan_only}, plumb::Error);
  EXPECT_THROW(plumb::BruteForceSearch3f(Points<3>{}), plumb::Error);
  const Points<3> one(1, Eigen::Vector3f(1, 2, 3));
  EXPECT_THROW(plumb::KdTree3f(one, KdTreeSettings{0}), plumb::Error);
  try {
    plumb::KdTree3f{nan_only};
    FAIL() << "expected plumb::Error";
  } catch (const plumb::Error& e) {
    EXPECT_NE(std::string(e.what()).find("KdTree"), std::string::npos) << e.what();
  }
}

TEST(KdTreeTest, ARebuiltTreeAnswersAsANewOne) {
  // Rebuilt over a larger cloud, a smaller one (its memory reused), then refused input: every
  // query answers as a tree built afresh over the same points.
  plumb::Rng rng(41);
  plumb::KdTree3f tree(make_cloud<3>(500, Shape::kUniform, 1));
  for (const auto& [n, shape, seed] : {std::tuple{4000, Shape::kClusters, 2}, std::tuple{900, Shape::kUniform, 3}}) {
    Points<3> pts = make_cloud<3>(static_cast<std::size_t>(n), shape, static_cast<std::uint64_t>(seed));
    pts[7] = Eigen::Vector3f(kNaN, 0, 0);
    tree.rebuild(pts);
    const plumb::KdTree3f fresh(pts);
    ASSERT_EQ(tree.size(), fresh.size());
    ASSERT_EQ(tree.num_input_points(), pts.size());
    for (int k = 0; k < 200; ++k) {
      const Eigen::Vector3f q = random_query<3>(rng, 12.0);
      const std::vector<Neighbor> a = tree.knn(q, 6), b = fresh.knn(q, 6);
      ASSERT_EQ(a.size(), b.size());
      for (std::size_t j = 0; j < a.size(); ++j) {
        ASSERT_EQ(a[j].index, b[j].index) << k;
        ASSERT_EQ(a[j].dist_sq, b[j].dist_sq) << k;
      }
    }
  }
  const std::size_t before = tree.size();
  const Eigen::Vector3f q(1, 2, 3);
  const std::vector<Neighbor> kept = tree.knn(q, 3);
  EXPECT_THROW(tree.rebuild(Points<3>(10, Eigen::Vector3f(kNaN, 0, 0))), plumb::Error);
  EXPECT_EQ(tree.size(), before);
  const std::vector<Neighbor> after = tree.knn(q, 3);
  ASSERT_EQ(after.size(), kept.size());
  for (std::size_t j = 0; j < kept.size(); ++j) EXPECT_EQ(after[j].index, kept[j].index);
}


TEST(KdTreeTest, NonFinitePointsAreSkipped) {
  Points<3> pts = make_cloud<3>(3000, Shape::kClusters, 41);
  plumb::Rng rng(42);
  std::size_t num_bad = 0;
  for (std::size_t i = 0; i < pts.size(); i += 1 + rng.uniform_index(12)) {
    pts[i][static_cast<int>(rng.uniform_index(3))] = (num_bad % 3 == 0) ? kInf : kNaN;
    ++num_bad;
  }
  const plumb::KdTree3f tree(pts);
  EXPECT_EQ(tree.size(), pts.size() - num_bad);
  EXPECT_EQ(tree.num_skipped(), num_bad);
  EXPECT_EQ(tree.num_input_points(), pts.size());
  const plumb::BruteForceSearch3f oracle(pts);
  for (int i = 0; i < 100; ++i) {
    const Eigen::Vector3f q = random_query<3>(rng, 12.0);
    expect_knn_equal(tree, oracle, pts, q, 10, "nan points");
    expect_radius_equal(tree, oracle, q, 1.0f, "nan points");
  }
  // Asking for everything returns exactly the finite points.
  EXPECT_EQ(tree.knn(Eigen::Vector3f::Zero(), pts.size()).size(), pts.size() - num_bad);
  EXPECT_EQ(tree.radius(Eigen::Vector3f::Zero(), kInf).size(), pts.size() - num_bad);
}

TEST(KdTreeTest, NonFiniteQueryFindsNothing) {
  const Points<3> pts = make_cloud<3>(100, Shape::kUniform, 51);
  const plumb::KdTree3f tree(pts);
  for (const Eigen::Vector3f& q :
       {Eigen::Vector3f(kNaN, 0, 0), Eigen::Vector3f(0, kInf, 0), Eigen::Vector3f(0, 0, -kInf)}) {
    std::vector<std::size_t> idx{1, 2};
    std::vector<float> d{1, 2};
    EXPECT_EQ(tree.knn(q, 3, idx, d), 0u);
    EXPECT_TRUE(idx.empty());
    EXPECT_TRUE(d.empty());
    EXPECT_FALSE(tree.nearest(q).has_value());
    EXPECT_EQ(tree.radius(q, 100.0f).size(), 0u);
  }
}

TEST(KdTreeTest, NearestBatchMatchesNearest) {
  const Points<3> pts = make_cloud<3>(2000, Shape::kClusters, 61);
  const plumb::KdTree3f tree(pts);
  plumb::Rng rng(62);
  Points<3> queries(300);
  for (auto& q : queries) q = random_query<3>(rng, 12.0);
  queries[5] = Eigen::Vector3f(kNaN, 0, 0);
  const auto batch = tree.nearest_batch(queries, 0.25f);
  ASSERT_EQ(batch.size(), queries.size());
  std::size_t num_found = 0;
  for (std::size_t i = 0; i < queries.size(); ++i) {
    const auto nb = tree.nearest(queries[i], 0.25f);
    EXPECT_EQ(batch[i].valid(), nb.has_value());
    if (nb) {
      EXPECT_EQ(batch[i].index, nb->index);
      ++num_found;
    } else {
      EXPECT_EQ(batch[i].index, plumb::kNoNeighbor);
    }
  }
  EXPECT_GT(num_found, 0u);
  EXPECT_LT(num_found, queries.size());
}

TEST(KdTreeTest, ConcurrentQueriesEqualSerial) {
  const Points<3> pts = make_cloud<3>(20000, Shape::kClusters, 71);
  const plumb::KdTree3f tree(pts);
  plumb::Rng rng(72);
  Points<3> queries(4000);
  for (auto& q : queries) q = random_query<3>(rng, 12.0);
  auto run = [&](std::size_t begin, std::size_t end, std::vector<std::vector<Neighbor>>& out) {
    for (std::size_t i = begin; i < end; ++i) {
      out[i] = tree.knn(queries[i], 8);
      const auto r = tree.radius(queries[i], 0.3f);
      out[i].insert(out[i].end(), r.begin(), r.end());
      if (auto nb = tree.nearest(queries[i])) out[i].push_back(*nb);
    }
  };
  std::vector<std::vector<Neighbor>> serial(queries.size());
  run(0, queries.size(), serial);
  std::vector<std::vector<Neighbor>> parallel(queries.size());
  std::vector<std::thread> threads;
  const std::size_t num_threads = 4;
  for (std::size_t t = 0; t < num_threads; ++t) {
    const std::size_t begin = t * queries.size() / num_threads;
    const std::size_t end = (t + 1) * queries.size() / num_threads;
    threads.emplace_back(run, begin, end, std::ref(parallel));
  }
  for (auto& th : threads) th.join();
  for (std::size_t i = 0; i < queries.size(); ++i) {
    ASSERT_EQ(parallel[i].size(), serial[i].size()) << i;
    for (std::size_t j = 0; j < serial[i].size(); ++j) {
      EXPECT_EQ(parallel[i][j].index, serial[i][j].index);
      EXPECT_EQ(parallel[i][j].dist_sq, serial[i][j].dist_sq);
    }
  }
}

#ifdef PLUMB_TEST_HAVE_PCD
TEST(KdTreeTest, RealRoomScanMatchesBruteForce) {
  PLUMB_REQUIRE_DATA(path, "cloud3d/pcl_room_scans/room_scan1.pcd");
  const plumb::PointCloud cloud = plumb::io::read_pcd(path);
  ASSERT_EQ(cloud.size(), 112586u);  // SOURCES.md
  const plumb::KdTree3f tree(cloud);
  const plumb::BruteForceSearch3f oracle(cloud);
  plumb::Rng rng(81);
  for (int i = 0; i < 1000; ++i) {
    // Half on data points, half perturbed by up to 0.5 m.
    Eigen::Vector3f q = cloud.points[rng.uniform_index(cloud.size())];
    if (i % 2 == 1) q += random_query<3>(rng, 0.5);
    expect_knn_equal(tree, oracle, cloud.points, q, 10, "room_scan1");
    if (i % 10 == 0) expect_radius_equal(tree, oracle, q, 0.2f, "room_scan1");
  }
}
#endif

}  // namespace

namespace {

TEST(KdTreeTest, DeepTreeFromExponentialSpacing) {
  // x = 4^-i: every midpoint split peels off one point, so the tree is ~n levels deep (this
  // exercises the recursive fallback of the search beyond its fixed stack of 64 levels).
  for (int n : {40, 74}) {
    Points<3> pts;
    for (int i = 0; i < n; ++i) pts.emplace_back(std::ldexp(1.0f, -2 * i), 0.5f, -0.25f);
    const plumb::KdTree3f tree(pts, KdTreeSettings{1, plumb::KdTreeSplit::kMidpoint});
    EXPECT_GE(tree.max_depth(), static_cast<std::size_t>(n - 2));
    const plumb::BruteForceSearch3f oracle(pts);
    plumb::Rng rng(91);
    for (int i = 0; i < 60; ++i) {
      Eigen::Vector3f q = pts[rng.uniform_index(pts.size())];
      if (i % 3 == 1) q.x() *= 1.3f;
      if (i % 3 == 2) q = random_query<3>(rng, 1.0);
      expect_knn_equal(tree, oracle, pts, q, 3, "deep n=" + std::to_string(n));
      expect_nearest_equal(tree, oracle, q, kInf, "deep");
      expect_radius_equal(tree, oracle, q, 0.01f, "deep");
    }
  }
}

}  // namespace
