// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// @brief The voxel keys and the stable radix sort of voxel_grid(), which segmentation's
///        sample_frame() shares, for plumb's own sources (not installed). VoxelKeyer and RadixPlan
///        stay inline: they are the per-point inner loop of the sort template.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <utility>
#include <vector>

#include "plumb/core/error.hpp"
#include "plumb/core/point_cloud.hpp"

#include "plumb/filters/voxel_grid.hpp"

namespace plumb::detail {

/// Number of bits needed to write v (0 for v == 0).
int bit_width_u64(std::uint64_t v);

/// Voxel key of a finite point inside the layout's bounds (every coordinate >= origin).
///
/// The documented coordinate is floor((p - min) / leaf) with a true division. Division is slow, so
/// the product q = (p - min) * (1 / leaf) is used instead where it provably has the same floor: q and
/// the quotient differ by less than 3.4e-16 * q <= 3.4e-16 * n_a (three roundings of at most 2^-53
/// each), so their floors can differ only when q lies within tol_a = 1e-15 * (n_a + 1) of an integer;
/// those points (e.g. exactly on a voxel border) are recomputed with the division.
class VoxelKeyer {
 public:
  explicit VoxelKeyer(const VoxelKeyLayout& layout)
      : layout_(layout), inv_leaf_(1.0 / layout.leaf_size) {
    constexpr std::uint64_t kFastLimit = std::uint64_t{1} << 40;  // q exact in int64 and double
    fast_ = std::isfinite(inv_leaf_);
    for (int a = 0; a < 3; ++a) {
      fast_ = fast_ && layout.n[a] <= kFastLimit;
      half_minus_tol_[a] = 0.5 - 1e-15 * (static_cast<double>(layout.n[a]) + 1.0);
    }
  }

  std::uint64_t key(const Vector3f& p) const {
    if (fast_) {
      const double qx = (static_cast<double>(p[0]) - layout_.origin[0]) * inv_leaf_;
      const double qy = (static_cast<double>(p[1]) - layout_.origin[1]) * inv_leaf_;
      const double qz = (static_cast<double>(p[2]) - layout_.origin[2]) * inv_leaf_;
      const std::int64_t tx = static_cast<std::int64_t>(qx);  // q >= 0: truncation is floor
      const std::int64_t ty = static_cast<std::int64_t>(qy);
      const std::int64_t tz = static_cast<std::int64_t>(qz);
      // |frac - 0.5| < 0.5 - tol  <=>  tol < frac < 1 - tol: no integer within tol of q.
      // (int & int: one branch for the three axes)
      const int safe =
          static_cast<int>(std::abs(qx - static_cast<double>(tx) - 0.5) < half_minus_tol_[0]) &
          static_cast<int>(std::abs(qy - static_cast<double>(ty) - 0.5) < half_minus_tol_[1]) &
          static_cast<int>(std::abs(qz - static_cast<double>(tz) - 0.5) < half_minus_tol_[2]);
      if (safe) {
        return static_cast<std::uint64_t>(tx) + layout_.stride_y * static_cast<std::uint64_t>(ty) +
               layout_.stride_z * static_cast<std::uint64_t>(tz);
      }
    }
    return exact(p[0], 0) + layout_.stride_y * exact(p[1], 1) + layout_.stride_z * exact(p[2], 2);
  }

 private:
  std::uint64_t exact(float x, int a) const {
    return static_cast<std::uint64_t>(
        std::floor((static_cast<double>(x) - layout_.origin[a]) / layout_.leaf_size));
  }

  const VoxelKeyLayout& layout_;
  double inv_leaf_;
  double half_minus_tol_[3] = {0.0, 0.0, 0.0};
  bool fast_ = false;
};

/// Digits of an LSD radix sort over `key_bits` bits: at most 11 bits per digit (a 2048-entry
/// histogram per pass stays in L1), the passes balanced.
struct RadixPlan {
  explicit RadixPlan(int key_bits) {
    num_passes = key_bits <= 0 ? 0 : (key_bits + 10) / 11;
    digit_bits = num_passes == 0 ? 0 : (key_bits + num_passes - 1) / num_passes;
    mask = (std::uint64_t{1} << digit_bits) - 1;
    hist.assign(static_cast<std::size_t>(num_passes) << digit_bits, 0);
  }
  /// Count key k in every pass's histogram.
  void count(std::uint64_t k) {
    std::uint32_t* h = hist.data();
    for (int pass = 0; pass < num_passes; ++pass, h += (std::size_t{1} << digit_bits)) {
      ++h[(k >> (pass * digit_bits)) & mask];
    }
  }
  int num_passes = 0;
  int digit_bits = 0;
  std::uint64_t mask = 0;
  std::vector<std::uint32_t> hist;  ///< num_passes histograms of 2^digit_bits counts
};

/// Stable LSD radix sort of a[0, n) by key_of(element), with histograms already counted in `plan`;
/// `tmp` is scratch of n elements. Passes whose digit is the same for every element are skipped.
/// @return the buffer (a or tmp) that holds the sorted sequence.
template <typename T, typename KeyOf>
T* radix_sort_by_key(T* a, T* tmp, std::size_t n, RadixPlan& plan, KeyOf key_of) {
  if (n < 2) return a;
  const std::size_t num_buckets = std::size_t{1} << plan.digit_bits;
  for (int pass = 0; pass < plan.num_passes; ++pass) {
    std::uint32_t* h = plan.hist.data() + static_cast<std::size_t>(pass) * num_buckets;
    const int shift = pass * plan.digit_bits;
    const std::uint64_t mask = plan.mask;
    if (h[(key_of(a[0]) >> shift) & mask] == n) continue;  // one bucket: nothing to do
    std::uint32_t sum = 0;
    for (std::size_t b = 0; b < num_buckets; ++b) {
      const std::uint32_t c = h[b];
      h[b] = sum;
      sum += c;
    }
    for (std::size_t i = 0; i < n; ++i) tmp[h[(key_of(a[i]) >> shift) & mask]++] = a[i];
    std::swap(a, tmp);
  }
  return a;
}

/// (key, source index) of a point when the two do not fit one 64-bit word together.
struct VoxelKeyIndex {
  std::uint64_t key;
  std::uint32_t index;
};

/// The end e of the run of equal keys in `sorted` (n items) that starts at b: the keys of [b, e)
/// are equal, e == n or the key of e differs. `sum` is the double sum of the run's points.
template <typename T, typename KeyOf, typename IndexOf>
std::size_t voxel_run_end(const std::vector<Vector3f>& pts, const T* sorted, std::size_t n, std::size_t b,
                          KeyOf key_of, IndexOf index_of, Vector3d& sum) {
  const std::uint64_t key = key_of(sorted[b]);
  std::size_t e = b + 1;
  sum = pts[index_of(sorted[b])].template cast<double>();
  while (e < n && key_of(sorted[e]) == key) {
    sum += pts[index_of(sorted[e])].template cast<double>();
    ++e;
  }
  return e;
}

/// Index of the point of the run [b, e) of `sorted` nearest to `c` (distances in double); ties
/// keep the first (lowest index).
template <typename T, typename IndexOf>
std::size_t nearest_in_run(const std::vector<Vector3f>& pts, const T* sorted, std::size_t b, std::size_t e,
                           const Vector3d& c, IndexOf index_of) {
  std::size_t best = index_of(sorted[b]);
  double best_d_sq = (pts[best].template cast<double>() - c).squaredNorm();
  for (std::size_t j = b + 1; j < e; ++j) {
    const std::size_t i = index_of(sorted[j]);
    const double d_sq = (pts[i].template cast<double>() - c).squaredNorm();
    if (d_sq < best_d_sq) {
      best_d_sq = d_sq;
      best = i;
    }
  }
  return best;
}

/// Bounding box of the finite points of a cloud and their number.
struct FiniteBounds {
  Vector3f lo;                 ///< componentwise minimum (meaningful when num_finite > 0)
  Vector3f hi;                 ///< componentwise maximum (meaningful when num_finite > 0)
  std::size_t num_finite = 0;  ///< points with three finite coordinates
};

/// The bounding box of the finite points of `pts` (float min/max are exact).
FiniteBounds finite_bounds(const std::vector<Vector3f>& pts);

/// Keys the `num_finite` finite points of `pts` (at least one, fewer than 2^32 points in all) on
/// `layout`, sorts them by key with a stable radix sort (source order is kept inside a voxel) and
/// calls `reduce(sorted, num_finite, key_of, index_of)`: `key_of(item)` is an item's voxel key,
/// `index_of(item)` its index in `pts`. An item packs key and index into one word where they fit.
template <typename Reduce>
void sort_by_voxel_key(const std::vector<Vector3f>& pts, std::size_t num_finite, const VoxelKeyLayout& layout,
                       Reduce&& reduce) {
  const std::size_t n = pts.size();
  const VoxelKeyer keyer(layout);
  RadixPlan plan(layout.key_bits);
  const bool all_finite = num_finite == n;
  const int index_bits = bit_width_u64(static_cast<std::uint64_t>(n - 1));
  if (layout.key_bits + index_bits <= 64) {
    // Packed: key in the high bits, source index in the low bits of one word.
    std::unique_ptr<std::uint64_t[]> items(new std::uint64_t[num_finite]);
    std::unique_ptr<std::uint64_t[]> tmp(new std::uint64_t[num_finite]);
    std::size_t m = 0;
    for (std::size_t i = 0; i < n; ++i) {
      if (!all_finite && !pts[i].allFinite()) continue;
      const std::uint64_t key = keyer.key(pts[i]);
      plan.count(key);
      items[m++] = (key << index_bits) | static_cast<std::uint64_t>(i);
    }
    auto key_of = [index_bits](std::uint64_t x) { return x >> index_bits; };
    const std::uint64_t index_mask = index_bits == 0 ? 0 : (~std::uint64_t{0} >> (64 - index_bits));
    auto index_of = [index_mask](std::uint64_t x) { return static_cast<std::size_t>(x & index_mask); };
    const std::uint64_t* sorted = radix_sort_by_key(items.get(), tmp.get(), num_finite, plan, key_of);
    reduce(sorted, num_finite, key_of, index_of);
  } else {
    std::unique_ptr<VoxelKeyIndex[]> items(new VoxelKeyIndex[num_finite]);
    std::unique_ptr<VoxelKeyIndex[]> tmp(new VoxelKeyIndex[num_finite]);
    std::size_t m = 0;
    for (std::size_t i = 0; i < n; ++i) {
      if (!all_finite && !pts[i].allFinite()) continue;
      const std::uint64_t key = keyer.key(pts[i]);
      plan.count(key);
      items[m++] = VoxelKeyIndex{key, static_cast<std::uint32_t>(i)};
    }
    auto key_of = [](const VoxelKeyIndex& x) { return x.key; };
    auto index_of = [](const VoxelKeyIndex& x) { return static_cast<std::size_t>(x.index); };
    const VoxelKeyIndex* sorted = radix_sort_by_key(items.get(), tmp.get(), num_finite, plan, key_of);
    reduce(sorted, num_finite, key_of, index_of);
  }
}

}  // namespace plumb::detail
