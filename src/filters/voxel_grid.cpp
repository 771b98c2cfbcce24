// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/filters/voxel_grid.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "plumb/core/error.hpp"
#include "plumb/core/point_cloud.hpp"
#include "plumb/core/status.hpp"

#include "filters/voxel_sort.hpp"

namespace plumb {
namespace detail {

int bit_width_u64(std::uint64_t v) {
  int bits = 0;
  while (v != 0) {
    ++bits;
    v >>= 1;
  }
  return bits;
}

VoxelKeyLayout make_voxel_key_layout(const Vector3d& min, const Vector3d& max,
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

FiniteBounds finite_bounds(const std::vector<Vector3f>& pts) {
  const std::size_t n = pts.size();
  float lo_x = std::numeric_limits<float>::infinity(), lo_y = lo_x, lo_z = lo_x;
  float hi_x = -lo_x, hi_y = hi_x, hi_z = hi_x;
  std::size_t num_finite = 0;
  std::size_t i = 0;
#if defined(__SSE2__)
  // One point per register (x, y, z and the next point's x, which is masked off), two points per
  // step into two sets of accumulators so that consecutive min/max chains overlap. A point with a
  // NaN or infinite coordinate is replaced by (+inf for the minimum, -inf for the maximum) without
  // a branch: LiDAR frames mix finite points and no-returns unpredictably. Min and max of floats
  // are exact, so the bounds are the scalar loop's (a zero's sign aside, which no key sees).
  static_assert(sizeof(Vector3f) == 3 * sizeof(float), "Vector3f is three packed floats");
  if (n >= 2) {
    const float* p = pts[0].data();
    const __m128 inf = _mm_set1_ps(std::numeric_limits<float>::infinity());
    const __m128 minus_inf = _mm_sub_ps(_mm_setzero_ps(), inf);
    __m128 lo = inf, lo2 = inf, hi = minus_inf, hi2 = minus_inf;
    __m128i count = _mm_setzero_si128();
    // A point's mask: all ones when its three coordinates are finite (x - x is 0 for a finite x,
    // NaN otherwise), else zero.
    const auto finite_mask = [](__m128 v) {
      const __m128 d = _mm_sub_ps(v, v);
      const int lanes = _mm_movemask_ps(_mm_cmpeq_ps(d, _mm_setzero_ps())) & 7;
      return _mm_castsi128_ps(_mm_set1_epi32(-static_cast<int>(lanes == 7)));
    };
    // The last point is read alone below: its register would reach past the array's end.
    for (; i + 3 <= n; i += 2, p += 6) {
      const __m128 v = _mm_loadu_ps(p);
      const __m128 v2 = _mm_loadu_ps(p + 3);
      const __m128 m = finite_mask(v), m2 = finite_mask(v2);
      lo = _mm_min_ps(_mm_or_ps(_mm_and_ps(m, v), _mm_andnot_ps(m, inf)), lo);
      hi = _mm_max_ps(_mm_or_ps(_mm_and_ps(m, v), _mm_andnot_ps(m, minus_inf)), hi);
      lo2 = _mm_min_ps(_mm_or_ps(_mm_and_ps(m2, v2), _mm_andnot_ps(m2, inf)), lo2);
      hi2 = _mm_max_ps(_mm_or_ps(_mm_and_ps(m2, v2), _mm_andnot_ps(m2, minus_inf)), hi2);
      // Each 64-bit lane counts the finite points (a mask lane is -1).
      count = _mm_sub_epi64(_mm_sub_epi64(count, _mm_castps_si128(m)), _mm_castps_si128(m2));
    }
    lo = _mm_min_ps(lo, lo2);
    hi = _mm_max_ps(hi, hi2);
    alignas(16) float l[4], h[4];
    alignas(16) std::int64_t c[2];
    _mm_store_ps(l, lo);
    _mm_store_ps(h, hi);
    _mm_store_si128(reinterpret_cast<__m128i*>(c), count);
    lo_x = l[0];
    lo_y = l[1];
    lo_z = l[2];
    hi_x = h[0];
    hi_y = h[1];
    hi_z = h[2];
    num_finite = static_cast<std::size_t>(c[0]);
  }
#endif
  for (; i < n; ++i) {
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

}  // namespace detail

VoxelGridResult voxel_grid(const PointCloud& cloud, const VoxelGridSettings& settings) {
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
