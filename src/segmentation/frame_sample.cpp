// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/segmentation/frame_sample.hpp"

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <limits>
#include <memory>

#include "plumb/core/error.hpp"
#include "plumb/search/kdtree.hpp"

#include "features/normals_detail.hpp"
#include "filters/voxel_sort.hpp"
#include "segmentation/frame_sample_detail.hpp"

namespace plumb {

namespace detail {

/// One pass over the runs of equal keys of `sorted` (ascending key, ascending index within a run):
/// the point nearest to the run's centroid, with voxel_grid()'s kNearestToCentroid rule and
/// arithmetic (double sum, times 1 / count, first of equal distances), so the sample is the same.
template <typename T, typename KeyOf, typename IndexOf>
void nearest_to_centroid_runs(const std::vector<Vector3f>& pts, const T* sorted, std::size_t n, KeyOf key_of,
                              IndexOf index_of, std::vector<std::size_t>& kept,
                              std::vector<std::uint64_t>& kept_keys) {
  std::size_t b = 0;
  while (b < n) {
    Vector3d sum;
    const std::size_t e = voxel_run_end(pts, sorted, n, b, key_of, index_of, sum);
    std::size_t best = index_of(sorted[b]);
    if (e - b > 1) {
      const Vector3d centroid = sum * (1.0 / static_cast<double>(e - b));
      best = nearest_in_run(pts, sorted, b, e, centroid, index_of);
    }
    kept.push_back(best);
    kept_keys.push_back(key_of(sorted[b]));
    b = e;
  }
}

/// The voxel sample of a frame with the voxel key of every kept point (ascending).
struct KeyedVoxelSample {
  std::vector<std::size_t> source;  ///< input index of the point kept in each voxel
  std::vector<std::uint64_t> keys;  ///< its voxel key (filters/voxel_grid.hpp layout), ascending
  VoxelKeyLayout layout;            ///< the grid (meaningful when `source` is not empty)
};

/// The input indices voxel_grid(cloud, {leaf, kNearestToCentroid}).indices would give, and their
/// voxel keys, from the coordinates alone: the same layout (filters/voxel_grid.hpp), keys and
/// stable radix sort, without copying the points or any field. Empty when no point is finite.
/// (A sort-free variant, hashing voxels in input order, was measured slower on a 32-beam frame:
/// its per-point updates of voxel sums jump across memory, the radix passes stream.)
KeyedVoxelSample voxel_sample_keyed(const std::vector<Vector3f>& pts, double leaf) {
  const FiniteBounds bounds = finite_bounds(pts);
  KeyedVoxelSample out;
  if (bounds.num_finite == 0) return out;
  PLUMB_CHECK(pts.size() <= std::numeric_limits<std::uint32_t>::max(),
              "sample_frame: clouds of more than 2^32 - 1 points are not supported, got " << pts.size());
  out.layout = make_voxel_key_layout(bounds.lo.cast<double>(), bounds.hi.cast<double>(), leaf);
  out.source.reserve(bounds.num_finite / 4);
  out.keys.reserve(bounds.num_finite / 4);
  sort_by_voxel_key(pts, bounds.num_finite, out.layout,
                    [&](const auto* sorted, std::size_t count, auto key_of, auto index_of) {
                      nearest_to_centroid_runs(pts, sorted, count, key_of, index_of, out.source, out.keys);
                    });
  return out;
}

/// The kept input indices of voxel_sample_keyed().
std::vector<std::size_t> voxel_sample(const std::vector<Vector3f>& pts, double leaf) {
  return voxel_sample_keyed(pts, leaf).source;
}

bool normal_from_covariance_fast(const Eigen::Matrix3d& cov, Vector3f& normal) {
  const double trace = cov.trace();
  if (!(trace > 0.0) || !std::isfinite(trace)) return false;
  const Eigen::Matrix3d c = cov * (1.0 / trace);  // eigenvalues in [0, 1], summing to 1
  const double c1 = c(0, 0) * c(1, 1) - c(0, 1) * c(0, 1) + c(0, 0) * c(2, 2) - c(0, 2) * c(0, 2) +
                    c(1, 1) * c(2, 2) - c(1, 2) * c(1, 2);
  const double det = c.determinant();
  // f(l) = l^3 - l^2 + c1 l - det, f(0) = -det <= 0.
  double l0 = 0.0;
  for (int it = 0; it < 64; ++it) {
    const double f = ((l0 - 1.0) * l0 + c1) * l0 - det;
    const double df = (3.0 * l0 - 2.0) * l0 + c1;
    if (!(df > 0.0)) break;
    const double step = -f / df;
    if (!(step > 1e-17)) break;
    l0 += step;
  }
  const double sum12 = 1.0 - l0;                        // l1 + l2
  const double prod12 = std::max(0.0, c1 - l0 * sum12);  // l1 l2
  const double l2 = 0.5 * sum12 + std::sqrt(std::max(0.0, 0.25 * sum12 * sum12 - prod12));
  const double l1 = l2 > 0.0 ? prod12 / l2 : 0.0;
  if (!(l1 - l0 >= 1e-3 * l2) || !std::isfinite(l0)) {
    float curv = 0.0f;
    return normal_from_covariance(cov, normal, curv);
  }
  Eigen::Matrix3d m = c;
  m.diagonal().array() -= l0;
  const Eigen::Vector3d a = m.row(0).cross(m.row(1)), b = m.row(0).cross(m.row(2)), d = m.row(1).cross(m.row(2));
  const double na = a.squaredNorm(), nb = b.squaredNorm(), nd = d.squaredNorm();
  const Eigen::Vector3d& v = na >= nb ? (na >= nd ? a : d) : (nb >= nd ? b : d);
  const double len = v.norm();
  if (!(len > 0.0)) return false;
  normal = (v / len).cast<float>();
  return normal.allFinite();
}

/// Normals of the sample by a kd-tree over it: estimate_normals() with the settings' k and radius
/// (FrameNormals::kNearest), for the points at or below normal_max_z.
void sample_normals_kdtree(const std::vector<Vector3f>& pts, const FrameSampleSettings& settings,
                           std::vector<Vector3f>& normals) {
  const KdTree<3> tree(pts);
  NormalSettings ns;
  ns.k = settings.normal_k;
  ns.radius = settings.normal_radius;
  ns.viewpoint = settings.viewpoint;
  ns.orient_to_viewpoint = true;
  if (std::isinf(settings.normal_max_z) && settings.normal_max_z > 0.0f) {
    normals = estimate_normals(pts, tree, pts, ns).normals;
    return;
  }
  std::vector<Vector3f> queries;
  std::vector<std::size_t> where;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    if (pts[i].z() <= settings.normal_max_z) {
      queries.push_back(pts[i]);
      where.push_back(i);
    }
  }
  normals.assign(pts.size(), Vector3f::Constant(std::numeric_limits<float>::quiet_NaN()));
  const NormalResult nr = estimate_normals(queries, tree, pts, ns);
  for (std::size_t j = 0; j < where.size(); ++j) normals[where[j]] = nr.normals[j];
}

/// Normals of a voxel sample (one point per voxel, ascending keys) by FrameNormals::kVoxelBlock:
/// the neighbours of a point are the k nearest of the sample points of the 3 x 3 x 3 voxels around
/// its own that lie within the radius; when fewer than normal_min_block lie there, the k nearest
/// within the radius (kd-tree built on first need), as kNearest.
///
/// The keys are x + n_x (y + n_y z) in voxel coordinates, so a row of voxels along x is a contiguous
/// run of the sample and the rows come in (z, y) order. The points of one row share the 3 x 3 rows
/// around it and their x only grows, so each of those rows is walked once by a cursor.
void sample_normals_voxel_block(const std::vector<Vector3f>& pts, const std::vector<std::uint64_t>& keys,
                                const VoxelKeyLayout& layout, const FrameSampleSettings& settings,
                                std::vector<Vector3f>& normals) {
  const std::size_t m = pts.size();
  const float nan = std::numeric_limits<float>::quiet_NaN();
  normals.assign(m, Vector3f::Constant(nan));
  if (m == 0) return;
  const std::uint64_t nx = layout.n[0], ny = layout.n[1], nz = layout.n[2];
  // x coordinate and (y, z) row of each sample point; the rows as runs of the sample.
  std::vector<std::int64_t> ix(m);
  std::vector<std::uint64_t> row_id;  // ascending
  std::vector<std::uint32_t> row_begin;
  for (std::size_t j = 0; j < m; ++j) {
    const std::uint64_t r = keys[j] / nx;
    ix[j] = static_cast<std::int64_t>(keys[j] - r * nx);
    if (row_id.empty() || row_id.back() != r) {
      row_id.push_back(r);
      row_begin.push_back(static_cast<std::uint32_t>(j));
    }
  }
  row_begin.push_back(static_cast<std::uint32_t>(m));
  const std::size_t num_rows = row_id.size();
  // Row of voxel row (y, z): a dense table when the (y, z) extent is small, else binary search.
  constexpr std::uint32_t kNoRow = std::numeric_limits<std::uint32_t>::max();
  const bool dense = ny <= (std::uint64_t{1} << 24) / nz && ny * nz <= std::max<std::uint64_t>(1u << 16, 16 * m);
  std::vector<std::uint32_t> row_table;
  if (dense) {
    row_table.assign(static_cast<std::size_t>(ny * nz), kNoRow);
    for (std::size_t r = 0; r < num_rows; ++r) row_table[static_cast<std::size_t>(row_id[r])] = static_cast<std::uint32_t>(r);
  }
  auto find_row = [&](std::uint64_t id) -> std::uint32_t {
    if (dense) return row_table[static_cast<std::size_t>(id)];
    const auto it = std::lower_bound(row_id.begin(), row_id.end(), id);
    return it != row_id.end() && *it == id ? static_cast<std::uint32_t>(it - row_id.begin()) : kNoRow;
  };

  const std::size_t k = settings.normal_k;
  const float r_sq = settings.normal_radius > 0.0f ? settings.normal_radius * settings.normal_radius
                                                   : std::numeric_limits<float>::infinity();
  std::vector<std::size_t> idx(k);
  std::vector<float> dist(k);
  std::unique_ptr<KdTree<3>> tree;  // for sparse places
  struct Cursor {
    std::uint32_t at, end;
  };
  Cursor cur[9];
  for (std::size_t r = 0; r < num_rows; ++r) {
    const std::int64_t iy = static_cast<std::int64_t>(row_id[r] % ny);
    const std::int64_t iz = static_cast<std::int64_t>(row_id[r] / ny);
    int num_cur = 0;
    for (std::int64_t z = std::max<std::int64_t>(0, iz - 1); z <= iz + 1 && z < static_cast<std::int64_t>(nz); ++z) {
      for (std::int64_t y = std::max<std::int64_t>(0, iy - 1); y <= iy + 1 && y < static_cast<std::int64_t>(ny); ++y) {
        const std::uint32_t nr = find_row(static_cast<std::uint64_t>(y) + ny * static_cast<std::uint64_t>(z));
        if (nr != kNoRow) cur[num_cur++] = Cursor{row_begin[nr], row_begin[nr + 1]};
      }
    }
    for (std::uint32_t q = row_begin[r]; q < row_begin[r + 1]; ++q) {
      const Vector3f& p = pts[q];
      const std::int64_t lo = ix[q] - 1, hi = ix[q] + 1;
      // Advance the cursors even for skipped queries: they must not fall behind.
      for (int c = 0; c < num_cur; ++c) {
        while (cur[c].at < cur[c].end && ix[cur[c].at] < lo) ++cur[c].at;
      }
      if (!(p.z() <= settings.normal_max_z)) continue;
      // The block's points within the radius (at most 27: one per voxel), then the k nearest of
      // them by sorted insertion (as the kd-tree's) when there are more than k.
      std::uint32_t block_idx[27];
      float block_d[27];
      std::size_t num_block = 0;
      for (int c = 0; c < num_cur; ++c) {
        for (std::uint32_t a = cur[c].at; a < cur[c].end && ix[a] <= hi; ++a) {
          const Vector3f& t = pts[a];
          const float dx = t.x() - p.x(), dy = t.y() - p.y(), dz = t.z() - p.z();
          const float d = dx * dx + dy * dy + dz * dz;
          block_idx[num_block] = a;
          block_d[num_block] = d;
          num_block += d <= r_sq ? 1 : 0;
        }
      }
      std::size_t count = 0;
      if (num_block <= k) {
        for (std::size_t b = 0; b < num_block; ++b) idx[b] = block_idx[b];
        count = num_block;
      } else {
        for (std::size_t b = 0; b < num_block; ++b) {
          const float d = block_d[b];
          if (count == k && !(d < dist[k - 1])) continue;
          detail::insert_k_best(dist.data(), idx.data(), count, k, d, block_idx[b]);
        }
      }
      std::size_t n = count;
      if (num_block < settings.normal_min_block) {  // a sparse place
        if (!tree) tree = std::make_unique<KdTree<3>>(pts);
        n = tree->knn(p, k, idx.data(), dist.data());
        while (n > 0 && dist[n - 1] > r_sq) --n;
      }
      Vector3f normal;
      if (n < 3 || !normal_from_covariance_fast(neighbourhood_covariance(pts, idx.data(), n), normal)) continue;
      if (normal.dot(settings.viewpoint - p) < 0.0f) normal = -normal;
      normals[q] = normal;
    }
  }
}

}  // namespace detail

FrameSample sample_frame(const PointCloud& cloud, const FrameSampleSettings& settings) {
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
    detail::KeyedVoxelSample vs = detail::voxel_sample_keyed(cloud.points, settings.voxel_size);
    out.source = std::move(vs.source);
    out.points.resize(out.source.size());
    for (std::size_t j = 0; j < out.source.size(); ++j) out.points[j] = cloud.points[out.source[j]];
    if (out.points.size() >= 3) {
      if (settings.normals == FrameNormals::kVoxelBlock) {
        detail::sample_normals_voxel_block(out.points, vs.keys, vs.layout, settings, out.normals);
      } else {
        detail::sample_normals_kdtree(out.points, settings, out.normals);
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
