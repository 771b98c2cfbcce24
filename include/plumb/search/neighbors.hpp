// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Result types shared by the nearest-neighbour searches (KdTree, BruteForceSearch).

#include <cstddef>
#include <limits>

namespace plumb {

/// @brief Index value meaning "no neighbour" (e.g. in nearest_batch() beyond the distance limit).
inline constexpr std::size_t kNoNeighbor = std::numeric_limits<std::size_t>::max();

/// @brief One neighbour of a query: the point's index in the caller's input and its squared distance.
struct Neighbor {
  std::size_t index = kNoNeighbor;  ///< index into the point vector (or cloud) the search was built from
  float dist_sq = std::numeric_limits<float>::infinity();  ///< squared Euclidean distance [m^2]

  /// @brief True when this names a point (index != kNoNeighbor).
  bool valid() const { return index != kNoNeighbor; }
};

namespace detail {

/// @brief Squared distance between two Dim-float arrays, summed in dimension order.
/// @note The kd-tree, its box bounds and the brute-force oracle all sum in this same order so that
///       a box bound never exceeds the distance of a point inside the box, in float.
template <int Dim>
inline float dist_sq(const float* a, const float* b) {
  float d = 0.0f;
  for (int k = 0; k < Dim; ++k) {
    const float t = a[k] - b[k];
    d += t * t;
  }
  return d;
}

}  // namespace detail
}  // namespace plumb
