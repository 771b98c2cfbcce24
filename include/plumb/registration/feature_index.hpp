// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// @brief Exact k-nearest-neighbour search among feature vectors (FPFH: 33 floats), for the
///        feature-space correspondences of SAC-IA. The 3-D KdTree of plumb/search covers Dim 2/3;
///        this is a small kd-tree for N-dimensional descriptors. FPFH of real scans lie near a
///        low-dimensional set (planes, edges, corners give few histogram shapes), so an exact
///        search prunes most of the tree although N is large.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <numeric>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Eigenvalues>

#include "plumb/core/error.hpp"

namespace plumb {

/// @brief Squared Euclidean distance of two feature vectors, summed in a fixed order (four
///        interleaved partial sums over dimensions i % 4, then (s0 + s1) + (s2 + s3)), so that
///        every caller gets bit-identical values.
template <std::size_t N>
inline float feature_distance_sq(const float* a, const float* b) {
  float s[4] = {0.0f, 0.0f, 0.0f, 0.0f};
  std::size_t i = 0;
  for (; i + 4 <= N; i += 4) {
    for (std::size_t l = 0; l < 4; ++l) {
      const float t = a[i + l] - b[i + l];
      s[l] += t * t;
    }
  }
  for (std::size_t l = 0; i < N; ++i, ++l) {
    const float t = a[i] - b[i];
    s[l] += t * t;
  }
  return (s[0] + s[1]) + (s[2] + s[3]);
}

/// @brief Static kd-tree over N-dimensional float vectors (a subset of a descriptor array), for
///        exact k-nearest queries.
///
/// The vectors are first rotated onto their principal axes (an orthonormal change of basis, so
/// distances are unchanged): the leading coordinates then carry most of the spread, which makes
/// both the cell bounds and the partial-distance cut-off in the leaves effective. Nodes split the
/// dimension of largest spread at the median (balanced whatever the clustering), down to leaves of
/// at most `leaf_size` vectors stored contiguously. Queries descend to the nearer side first and
/// visit the farther side only when the squared distance to its cell (accumulated over the split
/// dimensions, nanoflann-style) can still beat the current k-th distance.
/// @note Exact up to rounding: distances are feature_distance_sq() of the rotated vectors, which
///       differ from the unrotated ones by float rounding only (~1e-6 relative); ties go to the
///       smaller original index. Deterministic. Immutable after construction; queries are const
///       and thread-safe.
template <std::size_t N>
class FeatureKdTree {
 public:
  /// @brief Build over `data[ids[i]]` for all i (ids may be any subset, in any order).
  /// @param leaf_size most vectors per leaf, >= 1
  /// @throws plumb::Error for an out-of-range id, a non-finite value, leaf_size 0 or >= 2^32 ids
  FeatureKdTree(const std::vector<std::array<float, N>>& data, const std::vector<std::size_t>& ids,
                std::size_t leaf_size = 12);

  /// @brief Number of indexed vectors.
  std::size_t size() const { return ids_.size(); }

  /// @brief The k nearest indexed vectors of `query`, closest first (ties: smaller index first).
  /// @param indices, sq_dists caller buffers of at least k entries; receive original indices
  ///        (into the `data` of the constructor) and squared distances
  /// @return min(k, size())
  std::size_t knn(const float* query, std::size_t k, std::uint32_t* indices, float* sq_dists) const;

 private:
  struct Node {
    std::uint32_t a;  ///< inner: index of the right child (left child is next); leaf: first vector
    std::uint32_t b;  ///< leaf: one past the last vector
    std::int32_t dim; ///< split dimension, or -1 for a leaf
    float split;      ///< inner: left vectors have value <= split, right ones >= split
  };
  struct Result {
    std::uint32_t* idx;
    float* dist;
    std::size_t k;
    std::size_t count;
    float worst;
    /// Insert (d, id) keeping (distance, index) order; exact ties go to the smaller index.
    void add(float d, std::uint32_t id) {
      if (count == k && (d > worst || (d == worst && id > idx[k - 1]))) return;
      std::size_t j = count < k ? count++ : k - 1;
      while (j > 0 && (dist[j - 1] > d || (dist[j - 1] == d && idx[j - 1] > id))) {
        dist[j] = dist[j - 1];
        idx[j] = idx[j - 1];
        --j;
      }
      dist[j] = d;
      idx[j] = id;
      if (count == k) worst = dist[k - 1];
    }
  };

  std::uint32_t build(std::uint32_t begin, std::uint32_t end, std::vector<std::uint32_t>& order,
                      const std::vector<std::array<float, N>>& data);
  void rotate(const float* x, float* y) const;
  void search(std::uint32_t node, const float* q, float cell_dist, float* offsets, Result& res) const;

  std::size_t leaf_size_;
  Eigen::Matrix<double, static_cast<int>(N), static_cast<int>(N)> axes_;  ///< rows: principal axes, largest first
  Eigen::Matrix<double, static_cast<int>(N), 1> mean_;
  Eigen::Matrix<float, static_cast<int>(N), static_cast<int>(N)> axes_f_;  ///< axes_ in float
  Eigen::Matrix<float, static_cast<int>(N), 1> mean_f_;
  std::vector<float> rows_;          ///< vectors in tree order, N floats each
  std::vector<std::uint32_t> ids_;   ///< original index of row i
  std::vector<Node> nodes_;
};

/// @brief For every query `queries[query_ids[a]]`, the indices (into `data`) of its k nearest
///        vectors among `data[data_ids[b]]` (squared distance feature_distance_sq()), closest
///        first, ties by smaller index.
/// @return a flat vector: entries [a * k, (a + 1) * k) belong to query a (k = min(k, data_ids.size()))
/// @note Builds a FeatureKdTree over the data; exact and deterministic.
/// @throws plumb::Error for an out-of-range id or a non-finite value
template <std::size_t N>
std::vector<std::uint32_t> feature_knn(const std::vector<std::array<float, N>>& queries,
                                       const std::vector<std::size_t>& query_ids,
                                       const std::vector<std::array<float, N>>& data,
                                       const std::vector<std::size_t>& data_ids, std::size_t k);

// ---- implementation ---------------------------------------------------------------------------

template <std::size_t N>
FeatureKdTree<N>::FeatureKdTree(const std::vector<std::array<float, N>>& data,
                                const std::vector<std::size_t>& ids, std::size_t leaf_size)
    : leaf_size_(leaf_size) {
  PLUMB_CHECK(leaf_size >= 1, "FeatureKdTree: leaf_size must be >= 1");
  PLUMB_CHECK(ids.size() < std::numeric_limits<std::uint32_t>::max(),
              "FeatureKdTree: too many vectors (" << ids.size() << ")");
  using VecN = Eigen::Matrix<double, static_cast<int>(N), 1>;
  using MatN = Eigen::Matrix<double, static_cast<int>(N), static_cast<int>(N)>;
  mean_.setZero();
  axes_.setIdentity();
  for (std::size_t i = 0; i < ids.size(); ++i) {
    PLUMB_CHECK(ids[i] < data.size(), "FeatureKdTree: id " << ids[i] << " out of range for " << data.size());
    for (float v : data[ids[i]]) PLUMB_CHECK(std::isfinite(v), "FeatureKdTree: vector " << ids[i] << " is not finite");
  }
  if (ids.empty()) return;
  // Principal axes of the indexed vectors: covariance in double over at most ~512 of them (the
  // axes only steer the tree's splits; any orthonormal basis keeps the search exact).
  const std::size_t stride = std::max<std::size_t>(1, ids.size() / 512);
  std::size_t num_used = 0;
  for (std::size_t i = 0; i < ids.size(); i += stride, ++num_used)
    mean_ += Eigen::Map<const Eigen::Matrix<float, static_cast<int>(N), 1>>(data[ids[i]].data()).template cast<double>();
  mean_ /= static_cast<double>(num_used);
  MatN cov = MatN::Zero();
  for (std::size_t i = 0; i < ids.size(); i += stride) {
    const VecN x = Eigen::Map<const Eigen::Matrix<float, static_cast<int>(N), 1>>(data[ids[i]].data()).template cast<double>() - mean_;
    cov.noalias() += x * x.transpose();
  }
  const Eigen::SelfAdjointEigenSolver<MatN> es(cov);
  if (es.info() == Eigen::Success && es.eigenvectors().allFinite()) {
    for (int r = 0; r < static_cast<int>(N); ++r) axes_.row(r) = es.eigenvectors().col(static_cast<int>(N) - 1 - r).transpose();
  }
  axes_f_ = axes_.template cast<float>();
  mean_f_ = mean_.template cast<float>();
  // Rotate every vector at once (one float matrix product).
  Eigen::Matrix<float, static_cast<int>(N), Eigen::Dynamic> X(static_cast<int>(N), static_cast<Eigen::Index>(ids.size()));
  for (std::size_t i = 0; i < ids.size(); ++i)
    X.col(static_cast<Eigen::Index>(i)) = Eigen::Map<const Eigen::Matrix<float, static_cast<int>(N), 1>>(data[ids[i]].data()) - mean_f_;
  const Eigen::Matrix<float, static_cast<int>(N), Eigen::Dynamic> Y = axes_f_ * X;
  std::vector<std::array<float, N>> rotated(ids.size());
  std::vector<std::uint32_t> order(ids.size());
  for (std::size_t i = 0; i < ids.size(); ++i) {
    Eigen::Map<Eigen::Matrix<float, static_cast<int>(N), 1>> yi(rotated[i].data());
    yi = Y.col(static_cast<Eigen::Index>(i));
    order[i] = static_cast<std::uint32_t>(i);
  }
  nodes_.reserve(2 * (order.size() / leaf_size_ + 1));
  build(0, static_cast<std::uint32_t>(order.size()), order, rotated);
  rows_.resize(order.size() * N);
  ids_.resize(order.size());
  for (std::size_t i = 0; i < order.size(); ++i) {
    std::copy(rotated[order[i]].begin(), rotated[order[i]].end(), &rows_[i * N]);
    ids_[i] = static_cast<std::uint32_t>(ids[order[i]]);
  }
}

template <std::size_t N>
void FeatureKdTree<N>::rotate(const float* x, float* y) const {
  Eigen::Map<Eigen::Matrix<float, static_cast<int>(N), 1>> out(y);
  out.noalias() = axes_f_ * (Eigen::Map<const Eigen::Matrix<float, static_cast<int>(N), 1>>(x) - mean_f_);
}

template <std::size_t N>
std::uint32_t FeatureKdTree<N>::build(std::uint32_t begin, std::uint32_t end, std::vector<std::uint32_t>& order,
                                      const std::vector<std::array<float, N>>& data) {
  const std::uint32_t self = static_cast<std::uint32_t>(nodes_.size());
  nodes_.push_back(Node{begin, end, -1, 0.0f});
  if (end - begin <= leaf_size_) return self;
  // Dimension of largest spread.
  std::array<float, N> lo, hi;
  lo.fill(std::numeric_limits<float>::infinity());
  hi.fill(-std::numeric_limits<float>::infinity());
  for (std::uint32_t i = begin; i < end; ++i) {
    const auto& v = data[order[i]];
    for (std::size_t d = 0; d < N; ++d) {
      lo[d] = std::min(lo[d], v[d]);
      hi[d] = std::max(hi[d], v[d]);
    }
  }
  // Dimension of largest spread.
  std::size_t dim = 0;
  for (std::size_t d = 1; d < N; ++d)
    if (hi[d] - lo[d] > hi[dim] - lo[dim]) dim = d;
  if (!(hi[dim] > lo[dim])) return self;  // all vectors coincide: one leaf
  // Median split; ties on the split value may fall on either side (the bound allows it).
  const std::uint32_t mid = begin + (end - begin) / 2;
  auto by_dim = [&](std::uint32_t x, std::uint32_t y) {
    const float vx = data[x][dim], vy = data[y][dim];
    return vx < vy || (vx == vy && x < y);  // total order: the tree does not depend on the std lib
  };
  std::nth_element(order.begin() + begin, order.begin() + mid, order.begin() + end, by_dim);
  const float split = data[order[mid]][dim];
  nodes_[self].dim = static_cast<std::int32_t>(dim);
  nodes_[self].split = split;
  build(begin, mid, order, data);
  const std::uint32_t right = build(mid, end, order, data);
  nodes_[self].a = right;
  return self;
}

template <std::size_t N>
void FeatureKdTree<N>::search(std::uint32_t node_id, const float* q, float cell_dist, float* offsets,
                              Result& res) const {
  // A small relative slack on every bound keeps the search exact despite rounding.
  const Node& node = nodes_[node_id];
  if (node.dim < 0) {
    for (std::uint32_t i = node.a; i < node.b; ++i) {
      const float* x = &rows_[std::size_t{i} * N];
      // Rows are in principal-component order, so the leading dimensions carry most of the
      // distance: drop a row as soon as a partial sum cannot make the k best.
      const float limit = res.count < res.k ? std::numeric_limits<float>::infinity() : res.worst * 1.0001f;
      float acc[8] = {0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f};
      bool out = false;
      for (std::size_t d = 0; d + 8 <= N && !out; d += 8) {
        for (std::size_t l = 0; l < 8; ++l) {
          const float t = x[d + l] - q[d + l];
          acc[l] += t * t;
        }
        out = ((acc[0] + acc[1]) + (acc[2] + acc[3])) + ((acc[4] + acc[5]) + (acc[6] + acc[7])) > limit;
      }
      if (!out) res.add(feature_distance_sq<N>(q, x), ids_[i]);
    }
    return;
  }
  const std::size_t dim = static_cast<std::size_t>(node.dim);
  const float diff = q[dim] - node.split;
  const std::uint32_t near = diff <= 0.0f ? node_id + 1 : node.a;
  const std::uint32_t far = diff <= 0.0f ? node.a : node_id + 1;
  search(near, q, cell_dist, offsets, res);
  // Lower bound of the far cell: this dimension's offset replaced by the distance to the split.
  const float old = offsets[dim];
  const float now = diff * diff;
  const float far_dist = cell_dist - old + now;
  if (res.count < res.k || far_dist <= res.worst * 1.0001f) {
    offsets[dim] = now;
    search(far, q, std::max(far_dist, 0.0f), offsets, res);
    offsets[dim] = old;
  }
}

template <std::size_t N>
std::size_t FeatureKdTree<N>::knn(const float* query, std::size_t k, std::uint32_t* indices, float* sq_dists) const {
  k = std::min(k, ids_.size());
  if (k == 0) return 0;
  Result res{indices, sq_dists, k, 0, std::numeric_limits<float>::infinity()};
  std::array<float, N> q, offsets{};
  rotate(query, q.data());
  search(0, q.data(), 0.0f, offsets.data(), res);
  return res.count;
}

template <std::size_t N>
std::vector<std::uint32_t> feature_knn(const std::vector<std::array<float, N>>& queries,
                                       const std::vector<std::size_t>& query_ids,
                                       const std::vector<std::array<float, N>>& data,
                                       const std::vector<std::size_t>& data_ids, std::size_t k) {
  const FeatureKdTree<N> tree(data, data_ids);
  k = std::min(k, data_ids.size());
  std::vector<std::uint32_t> out(query_ids.size() * k);
  if (k == 0) return out;
  std::vector<float> dist(k);
  for (std::size_t a = 0; a < query_ids.size(); ++a) {
    PLUMB_CHECK(query_ids[a] < queries.size(),
                "feature_knn: query id " << query_ids[a] << " out of range for " << queries.size());
    const auto& q = queries[query_ids[a]];
    for (float v : q) PLUMB_CHECK(std::isfinite(v), "feature_knn: query " << query_ids[a] << " is not finite");
    tree.knn(q.data(), k, &out[a * k], dist.data());
  }
  return out;
}

}  // namespace plumb

#ifndef PLUMB_HEADER_ONLY
namespace plumb {
// The FPFH (33-D) tree is compiled once, in plumb_core (src/registration/feature_index.cpp): its
// 33 x 33 fixed-size eigen decomposition alone costs every including file many seconds to compile.
extern template class FeatureKdTree<33>;
extern template std::vector<std::uint32_t> feature_knn<33>(const std::vector<std::array<float, 33>>&,
                                                           const std::vector<std::size_t>&,
                                                           const std::vector<std::array<float, 33>>&,
                                                           const std::vector<std::size_t>&, std::size_t);
}  // namespace plumb
#endif
