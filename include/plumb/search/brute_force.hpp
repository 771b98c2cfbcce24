// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Exhaustive nearest-neighbour search: the test oracle for KdTree (same query interface).

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <optional>
#include <type_traits>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "plumb/core/error.hpp"
#include "plumb/core/point_cloud.hpp"
#include "plumb/search/neighbors.hpp"

namespace plumb {

/// @brief Exhaustive search over a copy of the points; O(n) per query (O(n log k) for knn).
///
/// Same rules as KdTree: non-finite input points are skipped (never returned), an input without a
/// single finite point throws plumb::Error, a non-finite query finds nothing. Ties are broken by the
/// smaller input index. Meant as an oracle for tests and for tiny sets.
/// @note All queries are const and thread-safe.
template <int Dim>
class BruteForceSearch {
  static_assert(Dim == 2 || Dim == 3, "BruteForceSearch supports Dim = 2 and 3");

 public:
  using Point = Eigen::Matrix<float, Dim, 1>;

  /// @brief Copy the points. @throws plumb::Error when no point is finite.
  explicit BruteForceSearch(const std::vector<Point>& points) : points_(points) {
    for (const Point& p : points_) num_finite_ += p.allFinite() ? 1 : 0;
    PLUMB_CHECK(num_finite_ > 0, "BruteForceSearch: input has no finite point (" << points.size()
                                                                              << " points given)");
  }

  /// @brief Build from a cloud's points (Dim = 3 only).
  template <int D = Dim, typename = std::enable_if_t<D == 3>>
  explicit BruteForceSearch(const PointCloud& cloud) : BruteForceSearch(cloud.points) {}

  /// @brief Number of searchable (finite) points.
  std::size_t size() const { return num_finite_; }

  /// @brief The k nearest points sorted by (distance, index); returns the count min(k, size()).
  std::size_t knn(const Point& query, std::size_t k, std::vector<std::size_t>& indices,
                  std::vector<float>& sq_dists) const {
    std::vector<Neighbor> all = collect(query, std::numeric_limits<float>::infinity());
    const std::size_t m = std::min(k, all.size());
    std::partial_sort(all.begin(), all.begin() + static_cast<std::ptrdiff_t>(m), all.end(), less);
    all.resize(m);
    split(all, indices, sq_dists);
    return m;
  }

  /// @brief knn() returning neighbours.
  std::vector<Neighbor> knn(const Point& query, std::size_t k) const {
    std::vector<std::size_t> idx;
    std::vector<float> d;
    knn(query, k, idx, d);
    return zip(idx, d);
  }

  /// @brief The nearest point with dist_sq <= max_dist_sq, if any.
  std::optional<Neighbor> nearest(const Point& query,
                                  float max_dist_sq = std::numeric_limits<float>::infinity()) const {
    std::vector<Neighbor> all = collect(query, max_dist_sq);
    if (all.empty()) return std::nullopt;
    return *std::min_element(all.begin(), all.end(), less);
  }

  /// @brief All points with dist_sq <= r * r; sorted by (distance, index) when `sorted`.
  std::size_t radius(const Point& query, float r, std::vector<std::size_t>& indices,
                     std::vector<float>& sq_dists, bool sorted = true) const {
    std::vector<Neighbor> all = r >= 0.0f ? collect(query, r * r) : std::vector<Neighbor>{};
    if (sorted) std::sort(all.begin(), all.end(), less);
    split(all, indices, sq_dists);
    return all.size();
  }

  /// @brief radius() returning neighbours.
  std::vector<Neighbor> radius(const Point& query, float r, bool sorted = true) const {
    std::vector<std::size_t> idx;
    std::vector<float> d;
    radius(query, r, idx, d, sorted);
    return zip(idx, d);
  }

 private:
  static bool less(const Neighbor& a, const Neighbor& b) {
    return a.dist_sq < b.dist_sq || (a.dist_sq == b.dist_sq && a.index < b.index);
  }

  std::vector<Neighbor> collect(const Point& query, float max_dist_sq) const {
    std::vector<Neighbor> out;
    if (!query.allFinite()) return out;
    out.reserve(max_dist_sq == std::numeric_limits<float>::infinity() ? points_.size() : 16);
    for (std::size_t i = 0; i < points_.size(); ++i) {
      if (!points_[i].allFinite()) continue;
      const float d = detail::dist_sq<Dim>(points_[i].data(), query.data());
      if (d <= max_dist_sq) out.push_back({i, d});
    }
    return out;
  }

  static void split(const std::vector<Neighbor>& in, std::vector<std::size_t>& indices,
                    std::vector<float>& sq_dists) {
    indices.resize(in.size());
    sq_dists.resize(in.size());
    for (std::size_t i = 0; i < in.size(); ++i) {
      indices[i] = in[i].index;
      sq_dists[i] = in[i].dist_sq;
    }
  }

  static std::vector<Neighbor> zip(const std::vector<std::size_t>& idx, const std::vector<float>& d) {
    std::vector<Neighbor> out(idx.size());
    for (std::size_t i = 0; i < idx.size(); ++i) out[i] = {idx[i], d[i]};
    return out;
  }

  std::vector<Point> points_;
  std::size_t num_finite_ = 0;
};

using BruteForceSearch2f = BruteForceSearch<2>;
using BruteForceSearch3f = BruteForceSearch<3>;

}  // namespace plumb
