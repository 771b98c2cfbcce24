// SPDX-License-Identifier: BSD-3-Clause
// KdTree::refit: a tree whose points moved answers exactly as the oracle over the moved points, on
// any number of threads, and a refit that does not fit the tree is refused.

#include "plumb/search/kdtree.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "kdtree_oracle.hpp"
#include "plumb/core/error.hpp"
#include "plumb/core/rng.hpp"
#include "plumb/search/brute_force.hpp"

namespace {

using namespace plumb::kdtree_test;

// Every query of a refitted tree against the oracle over the moved points.
template <int Dim>
void expect_refit_tree_exact(const KdTree<Dim>& tree, const Points<Dim>& pts, plumb::Rng& rng,
                             const std::string& what) {
  const BruteForceSearch<Dim> oracle(pts);
  const std::vector<const KdTree<Dim>*> trees{&tree};
  for (int i = 0; i < 120; ++i) {
    // Half the queries at the points themselves, nudged; half anywhere around the cloud.
    Eigen::Matrix<float, Dim, 1> q = random_query<Dim>(rng, 14.0);
    if (i % 2 == 0 && pts[static_cast<std::size_t>(i)].allFinite()) {
      q = pts[static_cast<std::size_t>(i)] + 0.01f * random_query<Dim>(rng, 1.0);
    }
    const std::string at = what + " query " + std::to_string(i);
    for (const std::size_t k : {std::size_t{1}, std::size_t{7}}) expect_knn_equal<Dim>(trees, oracle, pts, q, k, at);
    expect_bounded_knn_equal<Dim>(trees, oracle, pts, q, 5, 0.3f, at);
    expect_radius_equal<Dim>(trees, oracle, q, 0.4f, at);
    const std::optional<Neighbor> a = tree.nearest(q), b = oracle.nearest(q);
    ASSERT_EQ(a.has_value(), b.has_value()) << at;
    if (a) {
      EXPECT_EQ(a->dist_sq, b->dist_sq) << at;
    }
  }
}

template <int Dim>
void check_refit(std::uint64_t seed, int threads) {
  plumb::Rng rng(seed);
  Points<Dim> pts = make_cloud<Dim>(3000, Shape::kClusters, seed);
  pts[7] = Eigen::Matrix<float, Dim, 1>::Constant(kNaN);
  // 40 copies of one point: a bucket that is scanned as one point until they move apart.
  for (std::size_t i = 100; i < 140; ++i) pts[i] = pts[99];
  KdTree<Dim> tree(pts, KdTreeSettings{4, plumb::KdTreeSplit::kMean});
  const std::size_t nodes = tree.num_nodes();

  // Small rigid moves of eight groups of points (centimetres and a fraction of a degree, as a
  // building's elements move from their design), then every point sent anywhere: the cells no
  // longer fit the points at all, and the answers must still be exact.
  std::vector<Eigen::Matrix<float, Dim, Dim>> turn(8);
  std::vector<Eigen::Matrix<float, Dim, 1>> shift(8);
  for (std::size_t g = 0; g < 8; ++g) {
    const double a = rng.normal(0.0, 0.004);
    Eigen::Matrix<float, Dim, Dim> R = Eigen::Matrix<float, Dim, Dim>::Identity();
    R(0, 0) = R(1, 1) = static_cast<float>(std::cos(a));
    R(0, 1) = static_cast<float>(-std::sin(a));
    R(1, 0) = static_cast<float>(std::sin(a));
    turn[g] = R;
    for (int k = 0; k < Dim; ++k) shift[g][k] = static_cast<float>(rng.normal(0.0, 0.02));
  }
  Points<Dim> moved = pts;
  for (std::size_t i = 0; i < moved.size(); ++i) {
    if (i >= 99 && i < 120) continue;  // half of the copies stay together, half move
    if (moved[i].allFinite()) moved[i] = turn[i % 8] * moved[i] + shift[i % 8];
  }
  tree.refit(moved, threads);
  EXPECT_EQ(tree.num_nodes(), nodes);
  EXPECT_EQ(tree.size(), pts.size() - 1);
  expect_refit_tree_exact<Dim>(tree, moved, rng, "small moves");

  Points<Dim> scattered = pts;
  for (auto& p : scattered) {
    if (p.allFinite()) p = random_query<Dim>(rng, 12.0);
  }
  tree.refit(scattered, threads);
  expect_refit_tree_exact<Dim>(tree, scattered, rng, "scattered");
  tree.refit(pts, threads);  // and back where the tree was built
  expect_refit_tree_exact<Dim>(tree, pts, rng, "back");
}

TEST(KdTreeTest, ARefittedTreeAnswersExactlyOverTheMovedPoints) {
  check_refit<3>(51, 1);
  check_refit<2>(52, 1);
  // On three threads: the subtrees are refitted in any order, and the nodes above joined after.
  check_refit<3>(53, 3);
  check_refit<2>(54, 3);
}

TEST(KdTreeTest, ARefitIsTheSameOnAnyNumberOfThreads) {
  // Trees deep enough to be cut into many subtrees, and one whose root is its only leaf.
  for (const std::size_t n : {std::size_t{20000}, std::size_t{3}}) {
    plumb::Rng rng(55);
    const Points<3> pts = make_cloud<3>(n, Shape::kClusters, 56);
    Points<3> moved = pts;
    for (auto& p : moved) p += 0.05f * random_query<3>(rng, 1.0);
    std::vector<std::unique_ptr<plumb::KdTree3f>> trees;
    for (const int threads : {1, 2, 4, 0}) {
      trees.push_back(std::make_unique<plumb::KdTree3f>(pts, KdTreeSettings{6, plumb::KdTreeSplit::kMean}));
      trees.back()->refit(moved, threads);
    }
    for (int i = 0; i < 200; ++i) {
      const Eigen::Vector3f q = random_query<3>(rng, 14.0);
      const std::vector<Neighbor> one = trees[0]->knn(q, 5);
      for (std::size_t t = 1; t < trees.size(); ++t) {
        const std::vector<Neighbor> other = trees[t]->knn(q, 5);
        ASSERT_EQ(other.size(), one.size());
        for (std::size_t j = 0; j < one.size(); ++j) {
          EXPECT_EQ(other[j].index, one[j].index) << "tree " << t << " query " << i;
          EXPECT_EQ(other[j].dist_sq, one[j].dist_sq) << "tree " << t << " query " << i;
        }
      }
    }
    // And every one of them answers over the moved points.
    const BruteForceSearch<3> oracle(moved);
    const std::vector<const plumb::KdTree3f*> all{trees[0].get(), trees[1].get(), trees[2].get(), trees[3].get()};
    for (int i = 0; i < 50; ++i) {
      expect_knn_equal<3>(all, oracle, moved, random_query<3>(rng, 14.0), 3, "threads, n " + std::to_string(n));
    }
  }
  plumb::KdTree3f tree(make_cloud<3>(50, Shape::kUniform, 57));
  EXPECT_THROW(tree.refit(make_cloud<3>(50, Shape::kUniform, 58), -1), plumb::Error);
}

TEST(KdTreeTest, ARefitThatDoesNotFitIsRefusedAndChangesNothing) {
  Points<3> pts = make_cloud<3>(400, Shape::kUniform, 53);
  pts[3] = Eigen::Vector3f(kNaN, 0, 0);
  plumb::KdTree3f tree(pts);
  const Eigen::Vector3f q(1, -2, 0.5f);
  const std::vector<Neighbor> before = tree.knn(q, 4);
  Points<3> shorter(pts.begin(), pts.end() - 1);
  Points<3> more_nan = pts;
  more_nan[10] = Eigen::Vector3f(0, kInf, 0);
  Points<3> swapped = pts;  // as many finite points, but the missing one elsewhere
  swapped[3] = Eigen::Vector3f(50, 50, 50);
  swapped[200] = Eigen::Vector3f(kNaN, kNaN, kNaN);
  for (const Points<3>* bad : {&shorter, &more_nan, &swapped}) {
    try {
      tree.refit(*bad);
      ADD_FAILURE() << "expected plumb::Error";
    } catch (const plumb::Error& e) {
      EXPECT_NE(std::string(e.what()).find("KdTree::refit"), std::string::npos) << e.what();
    }
    const std::vector<Neighbor> after = tree.knn(q, 4);
    ASSERT_EQ(after.size(), before.size());
    for (std::size_t j = 0; j < before.size(); ++j) {
      EXPECT_EQ(after[j].index, before[j].index);
      EXPECT_EQ(after[j].dist_sq, before[j].dist_sq);
    }
  }
  // The copy of a point that stands where the swapped one went is never found.
  EXPECT_GT(tree.nearest(Eigen::Vector3f(50, 50, 50))->dist_sq, 100.0f);
}

}  // namespace
