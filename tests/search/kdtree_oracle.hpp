// SPDX-License-Identifier: BSD-3-Clause
// The kd-tree tests' clouds, queries and comparisons against the BruteForceSearch oracle.
#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "plumb/core/rng.hpp"
#include "plumb/search/brute_force.hpp"
#include "plumb/search/kdtree.hpp"

namespace plumb::kdtree_test {

using plumb::BruteForceSearch;
using plumb::KdTree;
using plumb::KdTreeSettings;
using plumb::Neighbor;

constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

enum class Shape { kUniform, kClusters };

template <int Dim>
using Points = std::vector<Eigen::Matrix<float, Dim, 1>>;

template <int Dim>
Points<Dim> make_cloud(std::size_t n, Shape shape, std::uint64_t seed) {
  plumb::Rng rng(seed);
  Points<Dim> pts(n);
  std::vector<Eigen::Matrix<float, Dim, 1>> centers(5);
  for (auto& c : centers) {
    for (int k = 0; k < Dim; ++k) c[k] = static_cast<float>(rng.uniform(-10.0, 10.0));
  }
  for (auto& p : pts) {
    if (shape == Shape::kUniform) {
      for (int k = 0; k < Dim; ++k) p[k] = static_cast<float>(rng.uniform(-10.0, 10.0));
    } else {
      const auto& c = centers[rng.uniform_index(centers.size())];
      const double sigma = 0.05 + 0.5 * static_cast<double>(rng.uniform_index(3));
      for (int k = 0; k < Dim; ++k) p[k] = c[k] + static_cast<float>(rng.normal(0.0, sigma));
    }
  }
  return pts;
}

template <int Dim>
Eigen::Matrix<float, Dim, 1> random_query(plumb::Rng& rng, double half_width) {
  Eigen::Matrix<float, Dim, 1> q;
  for (int k = 0; k < Dim; ++k) q[k] = static_cast<float>(rng.uniform(-half_width, half_width));
  return q;
}

template <int Dim>
float true_dist_sq(const Points<Dim>& pts, std::size_t i, const Eigen::Matrix<float, Dim, 1>& q) {
  return plumb::detail::dist_sq<Dim>(pts[i].data(), q.data());
}

// kNN of the tree equals the oracle's up to ties: the same sorted distances, every index distinct,
// finite, and at the distance reported for it.
template <int Dim>
void expect_knn_equal(const std::vector<const KdTree<Dim>*>& trees,
                      const BruteForceSearch<Dim>& oracle, const Points<Dim>& pts,
                      const Eigen::Matrix<float, Dim, 1>& q, std::size_t k,
                      const std::string& what) {
  std::vector<std::size_t> bi;
  std::vector<float> bd;
  const std::size_t bn = oracle.knn(q, k, bi, bd);
  for (const KdTree<Dim>* tree : trees) {
    std::vector<std::size_t> ti;
    std::vector<float> td;
    const std::size_t tn = tree->knn(q, k, ti, td);
    ASSERT_EQ(tn, bn) << what;
    ASSERT_EQ(ti.size(), tn) << what;
    ASSERT_EQ(td.size(), tn) << what;
    EXPECT_EQ(td, bd) << what << " k=" << k;
    std::set<std::size_t> seen;
    for (std::size_t i = 0; i < tn; ++i) {
      ASSERT_LT(ti[i], pts.size()) << what;
      EXPECT_TRUE(pts[ti[i]].allFinite()) << what;
      EXPECT_EQ(td[i], true_dist_sq<Dim>(pts, ti[i], q)) << what;
      seen.insert(ti[i]);
    }
    EXPECT_EQ(seen.size(), tn) << what << ": repeated index";
    EXPECT_TRUE(std::is_sorted(td.begin(), td.end())) << what;
  }
}

template <int Dim>
void expect_knn_equal(const KdTree<Dim>& tree, const BruteForceSearch<Dim>& oracle,
                      const Points<Dim>& pts, const Eigen::Matrix<float, Dim, 1>& q, std::size_t k,
                      const std::string& what) {
  expect_knn_equal<Dim>({&tree}, oracle, pts, q, k, what);
}

// Bounded kNN equals the oracle's kNN cut at the bound: the same sorted distances, indices at
// the distances reported for them.
template <int Dim>
void expect_bounded_knn_equal(const std::vector<const KdTree<Dim>*>& trees,
                              const BruteForceSearch<Dim>& oracle, const Points<Dim>& pts,
                              const Eigen::Matrix<float, Dim, 1>& q, std::size_t k, float max_dist_sq,
                              const std::string& what) {
  std::vector<std::size_t> bi;
  std::vector<float> bd;
  oracle.knn(q, k, bi, bd);
  while (!bd.empty() && !(bd.back() <= max_dist_sq)) bd.pop_back();
  for (const KdTree<Dim>* tree : trees) {
    std::vector<std::size_t> ti(k + 1);
    std::vector<float> td(k + 1);
    const std::size_t tn = tree->knn(q, k, ti.data(), td.data(), max_dist_sq);
    td.resize(tn);
    EXPECT_EQ(td, bd) << what << " k=" << k << " max_dist_sq=" << max_dist_sq;
    for (std::size_t i = 0; i < tn; ++i) {
      ASSERT_LT(ti[i], pts.size()) << what;
      EXPECT_EQ(td[i], true_dist_sq<Dim>(pts, ti[i], q)) << what;
    }
  }
}

template <int Dim>
void expect_radius_equal(const std::vector<const KdTree<Dim>*>& trees,
                         const BruteForceSearch<Dim>& oracle, const Eigen::Matrix<float, Dim, 1>& q,
                         float r, const std::string& what) {
  std::vector<std::size_t> bi;
  std::vector<float> bd;
  oracle.radius(q, r, bi, bd, true);
  for (const KdTree<Dim>* tree_ptr : trees) {
    const KdTree<Dim>& tree = *tree_ptr;
    std::vector<std::size_t> ti;
    std::vector<float> td;
    tree.radius(q, r, ti, td, true);
    EXPECT_EQ(td, bd) << what << " r=" << r;
    EXPECT_EQ(std::multiset<std::size_t>(ti.begin(), ti.end()),
              std::multiset<std::size_t>(bi.begin(), bi.end()))
        << what << " r=" << r;
    // Unsorted: same set.
    std::vector<std::size_t> ui;
    std::vector<float> ud;
    tree.radius(q, r, ui, ud, false);
    EXPECT_EQ(std::multiset<std::size_t>(ui.begin(), ui.end()),
              std::multiset<std::size_t>(bi.begin(), bi.end()))
        << what << " unsorted r=" << r;
  }
}

template <int Dim>
void expect_radius_equal(const KdTree<Dim>& tree, const BruteForceSearch<Dim>& oracle,
                         const Eigen::Matrix<float, Dim, 1>& q, float r, const std::string& what) {
  expect_radius_equal<Dim>({&tree}, oracle, q, r, what);
}

template <int Dim>
void expect_nearest_equal(const std::vector<const KdTree<Dim>*>& trees,
                          const BruteForceSearch<Dim>& oracle,
                          const Eigen::Matrix<float, Dim, 1>& q, float max_dist_sq,
                          const std::string& what) {
  const auto b = oracle.nearest(q, max_dist_sq);
  for (const KdTree<Dim>* tree : trees) {
    const auto t = tree->nearest(q, max_dist_sq);
    ASSERT_EQ(t.has_value(), b.has_value()) << what << " max_dist_sq=" << max_dist_sq;
    if (t) {
      EXPECT_EQ(t->dist_sq, b->dist_sq) << what;
      EXPECT_LE(t->dist_sq, max_dist_sq) << what;
    }
  }
}

template <int Dim>
void expect_nearest_equal(const KdTree<Dim>& tree, const BruteForceSearch<Dim>& oracle,
                          const Eigen::Matrix<float, Dim, 1>& q, float max_dist_sq,
                          const std::string& what) {
  expect_nearest_equal<Dim>({&tree}, oracle, q, max_dist_sq, what);
}

}  // namespace plumb::kdtree_test
