// SPDX-License-Identifier: BSD-3-Clause
#pragma once

// Bodies of plumb/filters/voxel_grid.hpp (included at its end).

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
#include "plumb/core/status.hpp"

namespace plumb {
namespace detail {

/// Number of bits needed to write v (0 for v == 0).
inline int bit_width_u64(std::uint64_t v) {
  int bits = 0;
  while (v != 0) {
    ++bits;
    v >>= 1;
  }
  return bits;
}

inline VoxelKeyLayout make_voxel_key_layout(const Vector3d& min, const Vector3d& max,
                                            double leaf_size) {
  VoxelKeyLayout layout;
  layout.origin = min;
  layout.leaf_size = leaf_size;
  constexpr std::uint64_t kMax = std::numeric_limits<std::uint64_t>::max();
  // 2^64 as a double; a per-axis count at or above it cannot even be converted.
  constexpr double kTwoPow64 = 18446744073709551616.0;
  bool fits = true;
  for (int a = 0; a < 3; ++a) {
    // Largest coordinate is floor((max - min) / leaf), the same expression the points use, so
    // every point's coordinate is <= n - 1 (division and subtraction are monotonic).
    const double top = std::floor((max[a] - min[a]) / leaf_size);
    if (!(top < kTwoPow64 - 1.0)) {
      fits = false;
      break;
    }
    layout.n[a] = static_cast<std::uint64_t>(top) + 1;
  }
  // n_x * n_y * n_z must not exceed 2^64, i.e. the largest key n_x*n_y*n_z - 1 must fit.
  if (fits && layout.n[1] > kMax / layout.n[0]) fits = false;
  if (fits) {
    const std::uint64_t nxy = layout.n[0] * layout.n[1];
    // nxy * nz - 1 <= kMax  <=>  nz - 1 <= (kMax - (nxy - 1)) / nxy
    if ((layout.n[2] - 1) > (kMax - (nxy - 1)) / nxy) fits = false;
  }
  PLUMB_CHECK(fits, "voxel_grid: leaf_size " << leaf_size << " m is too small for the cloud's extent "
                                             << (max[0] - min[0]) << " x " << (max[1] - min[1])
                                             << " x " << (max[2] - min[2])
                                             << " m: the voxel counts per axis multiply to more than "
                                                "2^64 and do not fit a 64-bit voxel key; use a "
                                                "larger leaf or crop the cloud first");
  layout.stride_y = layout.n[0];
  layout.stride_z = layout.n[0] * layout.n[1];
  const std::uint64_t max_key = (layout.n[0] - 1) + layout.stride_y * (layout.n[1] - 1) +
                                layout.stride_z * (layout.n[2] - 1);
  layout.key_bits = bit_width_u64(max_key);
  return layout;
}

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

/// One linear pass over runs of equal keys in `sorted` (ascending keys, ascending source index
/// within a run): centroids in double, then the nearest point or the averaged fields.
template <typename T, typename KeyOf, typename IndexOf>
void reduce_voxel_runs(const PointCloud& cloud, const T* sorted, std::size_t n, KeyOf key_of,
                       IndexOf index_of, const VoxelGridSettings& settings,
                       VoxelGridResult& result) {
  const std::vector<Vector3f>& pts = cloud.points;
  const bool nearest_mode = settings.mode == VoxelMode::kNearestToCentroid;
  PointCloud& out = result.cloud;

  if (nearest_mode) {
    result.indices.reserve(n / 4);
  } else {
    out.points.reserve(n / 4);
    if (cloud.has_normals()) out.normals.reserve(n / 4);
    if (cloud.has_intensities()) out.intensities.reserve(n / 4);
    if (cloud.has_rings()) out.rings.reserve(n / 4);
    if (cloud.has_times()) out.times.reserve(n / 4);
    if (cloud.has_labels()) out.labels.reserve(n / 4);
  }
  std::vector<std::size_t>& kept = result.indices;
  std::size_t b = 0;
  while (b < n) {
    Vector3d sum;
    const std::size_t e = voxel_run_end(pts, sorted, n, b, key_of, index_of, sum);
    ++result.num_voxels;
    const std::size_t count = e - b;
    if (count < settings.min_points_per_voxel) {
      ++result.num_sparse_voxels;
      b = e;
      continue;
    }
    if (count == 1) {  // the point is its own centroid
      const std::size_t i = index_of(sorted[b]);
      if (nearest_mode) {
        kept.push_back(i);
      } else {
        out.points.push_back(pts[i]);
        if (cloud.has_normals()) out.normals.push_back(cloud.normals[i]);
        if (cloud.has_intensities()) out.intensities.push_back(cloud.intensities[i]);
        if (cloud.has_rings()) out.rings.push_back(cloud.rings[i]);
        if (cloud.has_times()) out.times.push_back(cloud.times[i]);
        if (cloud.has_labels()) out.labels.push_back(cloud.labels[i]);
      }
      b = e;
      continue;
    }
    const double inv_count = 1.0 / static_cast<double>(count);
    const Vector3d centroid = sum * inv_count;
    if (nearest_mode) {
      kept.push_back(nearest_in_run(pts, sorted, b, e, centroid, index_of));
      b = e;
      continue;
    }
    // kCentroid.
    out.points.push_back(centroid.cast<float>());
    std::size_t nearest = std::numeric_limits<std::size_t>::max();
    auto get_nearest = [&]() {
      if (nearest == std::numeric_limits<std::size_t>::max()) {
        nearest = nearest_in_run(pts, sorted, b, e, centroid, index_of);
      }
      return nearest;
    };
    if (cloud.has_normals()) {
      Vector3d nsum = Vector3d::Zero();
      for (std::size_t j = b; j < e; ++j) nsum += cloud.normals[index_of(sorted[j])].template cast<double>();
      const double len = nsum.norm() * inv_count;
      if (len > 1e-6) {
        out.normals.push_back((nsum / nsum.norm()).cast<float>());
      } else {  // normals cancel out (or are not finite): keep the nearest point's
        out.normals.push_back(cloud.normals[get_nearest()]);
      }
    }
    auto mean_of = [&](const std::vector<float>& field) {
      double s = 0.0;
      for (std::size_t j = b; j < e; ++j) s += static_cast<double>(field[index_of(sorted[j])]);
      return static_cast<float>(s * inv_count);
    };
    if (cloud.has_intensities()) out.intensities.push_back(mean_of(cloud.intensities));
    if (cloud.has_rings()) out.rings.push_back(cloud.rings[get_nearest()]);
    if (cloud.has_times()) out.times.push_back(mean_of(cloud.times));
    if (cloud.has_labels()) out.labels.push_back(cloud.labels[get_nearest()]);
    b = e;
  }

  if (nearest_mode) {
    // Copy every field of the kept points (indices are valid by construction).
    const std::size_t m = kept.size();
    out.points.resize(m);
    for (std::size_t k = 0; k < m; ++k) out.points[k] = pts[kept[k]];
    auto copy = [&](const auto& src, auto& dst) {
      if (src.empty()) return;
      dst.resize(m);
      for (std::size_t k = 0; k < m; ++k) dst[k] = src[kept[k]];
    };
    copy(cloud.normals, out.normals);
    copy(cloud.intensities, out.intensities);
    copy(cloud.rings, out.rings);
    copy(cloud.times, out.times);
    copy(cloud.labels, out.labels);
  }
}

/// Bounding box of the finite points of a cloud and their number.
struct FiniteBounds {
  Vector3f lo;                 ///< componentwise minimum (meaningful when num_finite > 0)
  Vector3f hi;                 ///< componentwise maximum (meaningful when num_finite > 0)
  std::size_t num_finite = 0;  ///< points with three finite coordinates
};

/// The bounding box of the finite points of `pts` (float min/max are exact).
inline FiniteBounds finite_bounds(const std::vector<Vector3f>& pts) {
  const std::size_t n = pts.size();
  float lo_x = std::numeric_limits<float>::infinity(), lo_y = lo_x, lo_z = lo_x;
  float hi_x = -lo_x, hi_y = hi_x, hi_z = hi_x;
  std::size_t num_finite = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const float x = pts[i][0], y = pts[i][1], z = pts[i][2];
    if (!((x - x) + (y - y) + (z - z) == 0.0f)) continue;  // NaN unless all three are finite
    lo_x = std::min(lo_x, x);
    lo_y = std::min(lo_y, y);
    lo_z = std::min(lo_z, z);
    hi_x = std::max(hi_x, x);
    hi_y = std::max(hi_y, y);
    hi_z = std::max(hi_z, z);
    ++num_finite;
  }
  return FiniteBounds{Vector3f(lo_x, lo_y, lo_z), Vector3f(hi_x, hi_y, hi_z), num_finite};
}

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

}  // namespace detail

inline VoxelGridResult voxel_grid(const PointCloud& cloud, const VoxelGridSettings& settings) {
  const double leaf = settings.leaf_size;
  PLUMB_CHECK(std::isfinite(leaf) && leaf > 0.0,
              "voxel_grid: leaf_size must be finite and > 0, got " << leaf << " m");
  PLUMB_CHECK(settings.min_points_per_voxel >= 1, "voxel_grid: min_points_per_voxel must be >= 1");
  cloud.check_consistent("voxel_grid");

  VoxelGridResult result;
  const std::vector<Vector3f>& pts = cloud.points;
  const std::size_t n = pts.size();

  // Pass 1: bounding box of the finite points.
  const detail::FiniteBounds bounds = detail::finite_bounds(pts);
  result.num_dropped_non_finite = n - bounds.num_finite;
  if (bounds.num_finite == 0) {
    result.status = Status::kInsufficientData;
    return result;
  }
  const detail::VoxelKeyLayout layout =
      detail::make_voxel_key_layout(bounds.lo.cast<double>(), bounds.hi.cast<double>(), leaf);

  // Pass 2: keys and their radix histograms, then a stable radix sort (source order is kept
  // inside a voxel) and one pass over the runs of equal keys. No hashing, no per-voxel allocation.
  PLUMB_CHECK(n <= std::numeric_limits<std::uint32_t>::max(),
              "voxel_grid: clouds of more than 2^32 - 1 points are not supported, got " << n);
  detail::sort_by_voxel_key(pts, bounds.num_finite, layout,
                            [&](const auto* sorted, std::size_t count, auto key_of, auto index_of) {
                              detail::reduce_voxel_runs(cloud, sorted, count, key_of, index_of, settings, result);
                            });
  result.status = result.cloud.empty() ? Status::kInsufficientData : Status::kOk;
  return result;
}

}  // namespace plumb
