// SPDX-License-Identifier: BSD-3-Clause
#pragma once

// Bodies of plumb/segmentation/frame_sample.hpp (included at its end).

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <memory>

#include "plumb/search/kdtree.hpp"

namespace plumb {

namespace detail {

/// One pass over the runs of equal keys of `sorted` (ascending key, ascending index within a run):
/// the point nearest to the run's centroid, with voxel_grid()'s kNearestToCentroid rule and
/// arithmetic (double sum, times 1 / count, first of equal distances), so the sample is the same.
template <typename T, typename KeyOf, typename IndexOf>
void nearest_to_centroid_runs(const std::vector<Vector3f>& pts, const T* sorted, std::size_t n, KeyOf key_of,
                              IndexOf index_of, std::vector<std::size_t>& kept) {
  std::size_t b = 0;
  while (b < n) {
    const std::uint64_t key = key_of(sorted[b]);
    std::size_t e = b + 1;
    Vector3d sum = pts[index_of(sorted[b])].template cast<double>();
    while (e < n && key_of(sorted[e]) == key) {
      sum += pts[index_of(sorted[e])].template cast<double>();
      ++e;
    }
    std::size_t best = index_of(sorted[b]);
    if (e - b > 1) {
      const Vector3d centroid = sum * (1.0 / static_cast<double>(e - b));
      double best_d_sq = (pts[best].template cast<double>() - centroid).squaredNorm();
      for (std::size_t j = b + 1; j < e; ++j) {
        const std::size_t i = index_of(sorted[j]);
        const double d_sq = (pts[i].template cast<double>() - centroid).squaredNorm();
        if (d_sq < best_d_sq) {
          best_d_sq = d_sq;
          best = i;
        }
      }
    }
    kept.push_back(best);
    b = e;
  }
}

/// The input indices voxel_grid(cloud, {leaf, kNearestToCentroid}).indices would give, from the
/// coordinates alone: the same layout (filters/voxel_grid.hpp), keys and stable radix sort, without
/// copying the points or any field. Empty when no point is finite.
inline std::vector<std::size_t> voxel_sample(const std::vector<Vector3f>& pts, double leaf) {
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
  std::vector<std::size_t> kept;
  if (num_finite == 0) return kept;
  PLUMB_CHECK(n <= std::numeric_limits<std::uint32_t>::max(),
              "sample_frame: clouds of more than 2^32 - 1 points are not supported, got " << n);
  const VoxelKeyLayout layout = make_voxel_key_layout(Vector3f(lo_x, lo_y, lo_z).cast<double>(),
                                                      Vector3f(hi_x, hi_y, hi_z).cast<double>(), leaf);
  const VoxelKeyer keyer(layout);
  RadixPlan plan(layout.key_bits);
  const bool all_finite = num_finite == n;
  const int index_bits = bit_width_u64(static_cast<std::uint64_t>(n - 1));
  kept.reserve(num_finite / 4);
  if (layout.key_bits + index_bits <= 64) {
    // Key in the high bits, input index in the low bits of one word.
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
    nearest_to_centroid_runs(pts, sorted, num_finite, key_of, index_of, kept);
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
    nearest_to_centroid_runs(pts, sorted, num_finite, key_of, index_of, kept);
  }
  return kept;
}

}  // namespace detail

inline FrameSample sample_frame(const PointCloud& cloud, const FrameSampleSettings& settings) {
  const auto t0 = std::chrono::steady_clock::now();
  PLUMB_CHECK(std::isfinite(settings.voxel_size) && settings.voxel_size > 0.0,
              "sample_frame: voxel_size = " << settings.voxel_size << " must be finite and > 0");
  PLUMB_CHECK(settings.normal_k >= 3, "sample_frame: normal_k = " << settings.normal_k << " must be >= 3");
  PLUMB_CHECK(!std::isnan(settings.normal_max_z), "sample_frame: normal_max_z is NaN");
  cloud.check_consistent("sample_frame");
  FrameSample out;
  out.voxel_size = settings.voxel_size;
  for (const Vector3f& p : cloud.points) out.num_finite += p.allFinite() ? 1 : 0;
  if (out.num_finite >= 3) {
    out.source = detail::voxel_sample(cloud.points, settings.voxel_size);
    out.points.resize(out.source.size());
    for (std::size_t j = 0; j < out.source.size(); ++j) out.points[j] = cloud.points[out.source[j]];
    if (out.points.size() >= 3) {
      const KdTree<3> tree(out.points);
      NormalSettings ns;
      ns.k = settings.normal_k;
      ns.radius = settings.normal_radius;
      ns.viewpoint = settings.viewpoint;
      ns.orient_to_viewpoint = true;
      if (std::isinf(settings.normal_max_z) && settings.normal_max_z > 0.0f) {
        out.normals = estimate_normals(out.points, tree, out.points, ns).normals;
      } else {
        std::vector<Vector3f> queries;
        std::vector<std::size_t> where;
        for (std::size_t i = 0; i < out.points.size(); ++i) {
          if (out.points[i].z() <= settings.normal_max_z) {
            queries.push_back(out.points[i]);
            where.push_back(i);
          }
        }
        out.normals.assign(out.points.size(), Vector3f::Constant(std::numeric_limits<float>::quiet_NaN()));
        const NormalResult nr = estimate_normals(queries, tree, out.points, ns);
        for (std::size_t j = 0; j < where.size(); ++j) out.normals[where[j]] = nr.normals[j];
      }
      out.status = Status::kOk;
    } else {
      out.points.clear();
      out.source.clear();
    }
  }
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

}  // namespace plumb
