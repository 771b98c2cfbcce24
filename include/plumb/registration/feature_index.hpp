// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// @brief k most similar feature vectors (FPFH: 33 floats) of many queries at once, for the
///        feature-space correspondences of SAC-IA. The 3-D KdTree of plumb/search covers Dim 2/3;
///        in 33-D a tree visits most leaves, so this is a blocked brute force instead.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "plumb/core/error.hpp"

namespace plumb {

/// @brief For every query `queries[query_ids[a]]`, the indices (into `data`) of its k nearest
///        vectors among `data[data_ids[b]]` in Euclidean distance, closest first.
/// @return a flat vector: entries [a * k, (a + 1) * k) belong to query a (k = min(k, data_ids.size()))
/// @note Distances |q|^2 + |d|^2 - 2 q.d come from a float matrix product over blocks of queries
///       (so the cost is one GEMM, O(n m N)); the best k + 8 by that value are re-ranked by the
///       exact squared distance summed in dimension order, ties by smaller index. Deterministic.
/// @throws plumb::Error for an out-of-range id or a non-finite value
template <std::size_t N>
std::vector<std::uint32_t> feature_knn(const std::vector<std::array<float, N>>& queries,
                                       const std::vector<std::size_t>& query_ids,
                                       const std::vector<std::array<float, N>>& data,
                                       const std::vector<std::size_t>& data_ids, std::size_t k) {
  using MatrixXfR = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  const std::size_t n = query_ids.size();
  const std::size_t m = data_ids.size();
  k = std::min(k, m);
  std::vector<std::uint32_t> out(n * k);
  if (n == 0 || k == 0) return out;
  PLUMB_CHECK(m < std::numeric_limits<std::uint32_t>::max(), "feature_knn: too many features (" << m << ")");
  auto fill = [](const std::vector<std::array<float, N>>& src, const std::vector<std::size_t>& ids,
                 const char* what) {
    MatrixXfR M(static_cast<Eigen::Index>(ids.size()), static_cast<Eigen::Index>(N));
    for (std::size_t i = 0; i < ids.size(); ++i) {
      PLUMB_CHECK(ids[i] < src.size(), "feature_knn: " << what << " id " << ids[i] << " out of range for " << src.size());
      for (std::size_t d = 0; d < N; ++d) {
        PLUMB_CHECK(std::isfinite(src[ids[i]][d]), "feature_knn: " << what << " " << ids[i] << " is not finite");
        M(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(d)) = src[ids[i]][d];
      }
    }
    return M;
  };
  const MatrixXfR Q = fill(queries, query_ids, "query");
  const MatrixXfR D = fill(data, data_ids, "data");
  const Eigen::VectorXf d_norm = D.rowwise().squaredNorm();
  const std::size_t keep = std::min(m, k + 8);
  constexpr std::size_t kBlock = 256;
  MatrixXfR G;
  std::vector<std::pair<float, std::uint32_t>> row(keep);
  std::vector<std::pair<float, std::uint32_t>> best(keep);
  for (std::size_t a0 = 0; a0 < n; a0 += kBlock) {
    const Eigen::Index rows = static_cast<Eigen::Index>(std::min(kBlock, n - a0));
    G.noalias() = Q.middleRows(static_cast<Eigen::Index>(a0), rows) * D.transpose();
    for (Eigen::Index r = 0; r < rows; ++r) {
      // The `keep` smallest values, insertion-sorted (most values fail the first comparison).
      std::size_t count = 0;
      for (std::size_t b = 0; b < m; ++b) {
        const float v = d_norm(static_cast<Eigen::Index>(b)) - 2.0f * G(r, static_cast<Eigen::Index>(b));
        if (count == keep && !(v < row[keep - 1].first)) continue;
        std::size_t j = count < keep ? count++ : keep - 1;
        while (j > 0 && row[j - 1].first > v) {
          row[j] = row[j - 1];
          --j;
        }
        row[j] = {v, static_cast<std::uint32_t>(b)};
      }
      const auto& q = queries[query_ids[a0 + static_cast<std::size_t>(r)]];
      for (std::size_t j = 0; j < keep; ++j) {
        const auto& f = data[data_ids[row[j].second]];
        float dist = 0.0f;
        for (std::size_t d = 0; d < N; ++d) {
          const float t = f[d] - q[d];
          dist += t * t;
        }
        best[j] = {dist, row[j].second};
      }
      std::partial_sort(best.begin(), best.begin() + static_cast<std::ptrdiff_t>(k), best.end());
      for (std::size_t j = 0; j < k; ++j)
        out[(a0 + static_cast<std::size_t>(r)) * k + j] = static_cast<std::uint32_t>(data_ids[best[j].second]);
    }
  }
  return out;
}

}  // namespace plumb
