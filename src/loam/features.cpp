// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/loam/features.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "plumb/core/error.hpp"

namespace plumb {

double loam_cosine(const Vector3d& prev, const Vector3d& point, const Vector3d& next) {
  // Zhou et al. 2021, eq. 5: cos = (d_{i-1,i}^2 + d_{i,i+1}^2 - d_{i-1,i+1}^2) / (2 d_{i-1,i} d_{i,i+1})
  const double a_sq = (point - prev).squaredNorm();
  const double b_sq = (next - point).squaredNorm();
  const double c_sq = (next - prev).squaredNorm();
  const double denom = 2.0 * std::sqrt(a_sq * b_sq);
  if (!(denom > 0.0)) return std::numeric_limits<double>::quiet_NaN();
  return std::clamp((a_sq + b_sq - c_sq) / denom, -1.0, 1.0);
}

namespace loam_detail {

void check_feature_settings(const LoamFeatureSettings& s) {
  PLUMB_CHECK(std::isfinite(s.plane_cos_max) && s.plane_cos_max >= -1.0 && s.plane_cos_max <= 1.0,
              "extract_loam_features: plane_cos_max must be in [-1, 1], got " << s.plane_cos_max);
  PLUMB_CHECK(std::isfinite(s.edge_cos_abs_max) && s.edge_cos_abs_max >= 0.0 && s.edge_cos_abs_max <= 1.0,
              "extract_loam_features: edge_cos_abs_max must be in [0, 1], got " << s.edge_cos_abs_max);
  PLUMB_CHECK(s.num_sectors >= 1, "extract_loam_features: num_sectors must be >= 1, got " << s.num_sectors);
  PLUMB_CHECK(s.max_planes_per_sector >= 0 && s.max_plane_candidates_per_sector >= 0 &&
                  s.max_edges_per_sector >= 0 && s.max_edge_candidates_per_sector >= 0,
              "extract_loam_features: per-sector feature counts must be >= 0");
  PLUMB_CHECK(s.neighbor_offset >= 1, "extract_loam_features: neighbor_offset must be >= 1, got "
                                          << s.neighbor_offset);
  PLUMB_CHECK(s.max_neighbor_column_gap >= 1,
              "extract_loam_features: max_neighbor_column_gap must be >= 1, got " << s.max_neighbor_column_gap);
  PLUMB_CHECK(std::isfinite(s.occlusion_range_jump) && s.occlusion_range_jump > 0.0,
              "extract_loam_features: occlusion_range_jump must be > 0, got " << s.occlusion_range_jump);
  PLUMB_CHECK(s.occlusion_span >= 0 && s.suppression_radius >= 0,
              "extract_loam_features: occlusion_span and suppression_radius must be >= 0");
  PLUMB_CHECK(s.plane_pool_stride >= 1,
              "extract_loam_features: plane_pool_stride must be >= 1, got " << s.plane_pool_stride);
  PLUMB_CHECK(std::isfinite(s.parallel_beam_ratio) && s.parallel_beam_ratio > 0.0,
              "extract_loam_features: parallel_beam_ratio must be > 0, got " << s.parallel_beam_ratio);
}

void push_feature(const PointCloud& cloud, std::size_t index, int row, PointCloud& out,
                  std::vector<std::size_t>& indices) {
  out.points.push_back(cloud.points[index]);
  out.rings.push_back(static_cast<std::uint16_t>(row));
  if (cloud.has_times()) out.times.push_back(cloud.times[index]);
  indices.push_back(index);
}

void push_feature(const PointCloud& cloud, std::size_t index, int row, PointCloud& out) {
  out.points.push_back(cloud.points[index]);
  out.rings.push_back(static_cast<std::uint16_t>(row));
  if (cloud.has_times()) out.times.push_back(cloud.times[index]);
}

/// One ring of the range image, its points in column order, and the per-point state of the
/// selection. Reused from ring to ring.
struct LoamRing {
  std::vector<int> col;                       // column of each point
  std::vector<std::size_t> idx;               // its cloud index
  std::vector<double> rng, cosv;              // its range; its cosine (NaN: not scored)
  std::vector<char> usable, picked;           // not occluded / parallel; picked or suppressed
  std::vector<std::pair<double, int>> order;  // (key, position) sorted; ties by position = column
  int size() const { return static_cast<int>(col.size()); }
};

/// Position s in a ring as an index into its vectors.
std::size_t ring_at(int s) { return static_cast<std::size_t>(s); }

/// Gathers the points of image row `row` into `ring` and resets its per-point state.
void gather_ring(const PointCloud& cloud, const RangeImage& image, int row, LoamRing& ring) {
  ring.col.clear();
  ring.idx.clear();
  ring.rng.clear();
  for (int c = 0; c < image.num_columns; ++c) {
    const std::int32_t i = image.at(row, c);
    if (i == RangeImage::kEmpty) continue;
    PLUMB_CHECK(static_cast<std::size_t>(i) < cloud.size(),
                "extract_loam_features: range image pixel holds index " << i << " beyond the cloud");
    ring.col.push_back(c);
    ring.idx.push_back(static_cast<std::size_t>(i));
    ring.rng.push_back(image.range_at(row, c));
  }
  const std::size_t n = ring.col.size();
  ring.usable.assign(n, 1);
  ring.picked.assign(n, 0);
  ring.cosv.assign(n, std::numeric_limits<double>::quiet_NaN());
}

/// Marks the ring's occluded and parallel-beam points unusable (LOAM), counting them in `f`.
void mark_unreliable(const LoamFeatureSettings& settings, LoamRing& ring, LoamFeatures& f) {
  const int n = ring.size();
  const auto U = ring_at;
  const std::vector<double>& rng = ring.rng;
  std::vector<char>& usable = ring.usable;
  // Occluded points (LOAM): the far side of a range jump between adjacent points.
  for (int s = 0; s + 1 < n; ++s) {
    if (ring.col[U(s + 1)] - ring.col[U(s)] > settings.max_neighbor_column_gap) continue;
    const double dr = rng[U(s)] - rng[U(s + 1)];
    if (dr > settings.occlusion_range_jump) {
      for (int t = std::max(0, s - settings.occlusion_span + 1); t <= s; ++t) {
        if (usable[U(t)]) { usable[U(t)] = 0; ++f.num_occluded; }
      }
    } else if (-dr > settings.occlusion_range_jump) {
      for (int t = s + 1; t <= std::min(n - 1, s + settings.occlusion_span); ++t) {
        if (usable[U(t)]) { usable[U(t)] = 0; ++f.num_occluded; }
      }
    }
  }
  // Parallel beams (LOAM): range differs from both adjacent points by a large fraction.
  for (int s = 1; s + 1 < n; ++s) {
    const double lim = settings.parallel_beam_ratio * rng[U(s)];
    if (usable[U(s)] && std::abs(rng[U(s - 1)] - rng[U(s)]) > lim && std::abs(rng[U(s + 1)] - rng[U(s)]) > lim) {
      usable[U(s)] = 0;
      ++f.num_parallel;
    }
  }
}

/// Scores the ring's usable points with the cosine of Zhou et al. 2021, eq. 5, on the points k
/// places before and after, counting them per sector and filling the plane and edge pools.
void score_ring(const PointCloud& cloud, int num_columns, int row, const LoamFeatureSettings& settings,
                LoamRing& ring, LoamFeatures& f) {
  const int n = ring.size();
  const int k = settings.neighbor_offset;
  const int max_gap = settings.max_neighbor_column_gap;
  const auto U = ring_at;
  const std::vector<int>& col = ring.col;
  const std::vector<std::size_t>& idx = ring.idx;
  int plane_pool_count = 0;
  for (int s = k; s + k < n; ++s) {
    if (!ring.usable[U(s)]) continue;
    if (col[U(s)] - col[U(s - k)] > max_gap || col[U(s + k)] - col[U(s)] > max_gap) continue;
    const double c = loam_cosine(cloud.points[idx[U(s - k)]].cast<double>(), cloud.points[idx[U(s)]].cast<double>(),
                                 cloud.points[idx[U(s + k)]].cast<double>());
    if (std::isnan(c)) continue;
    ring.cosv[U(s)] = c;
    const int sector = static_cast<int>(static_cast<long long>(col[U(s)]) * settings.num_sectors / num_columns);
    LoamSectorCounts& sc = f.sector_counts[U(row * settings.num_sectors + sector)];
    ++sc.num_scored;
    ++f.num_scored;
    if (c <= settings.plane_cos_max) {
      ++sc.num_plane_interval;
      ++f.num_plane_interval;
      if (plane_pool_count++ % settings.plane_pool_stride == 0) push_feature(cloud, idx[U(s)], row, f.plane_pool);
    }
    if (std::abs(c) <= settings.edge_cos_abs_max) {
      ++sc.num_edge_interval;
      ++f.num_edge_interval;
      push_feature(cloud, idx[U(s)], row, f.edge_pool);
    }
  }
}

/// Marks the point at position s and its neighbours within suppression_radius (up to a column gap) picked.
void suppress_around(int s, const LoamFeatureSettings& settings, LoamRing& ring) {
  const int n = ring.size();
  const auto U = ring_at;
  const int max_gap = settings.max_neighbor_column_gap;
  ring.picked[U(s)] = 1;
  for (int t = s + 1; t <= std::min(n - 1, s + settings.suppression_radius); ++t) {
    if (ring.col[U(t)] - ring.col[U(t - 1)] > max_gap) break;
    ring.picked[U(t)] = 1;
  }
  for (int t = s - 1; t >= std::max(0, s - settings.suppression_radius); --t) {
    if (ring.col[U(t + 1)] - ring.col[U(t)] > max_gap) break;
    ring.picked[U(t)] = 1;
  }
}

/// Where picked features of one kind go: the first `limit` to `out`, the next `candidate_limit` to
/// `candidates`.
struct LoamPickTarget {
  PointCloud& out;
  std::vector<std::size_t>& indices;
  std::size_t& count;
  std::size_t limit;
  PointCloud& candidates;
  std::vector<std::size_t>& candidate_indices;
  std::size_t& candidate_count;
  std::size_t candidate_limit;
};

/// Picks the points of ring.order (sorted) not picked yet into `target`, suppressing around each.
void pick_in_order(const PointCloud& cloud, int row, const LoamFeatureSettings& settings, LoamRing& ring,
                   const LoamPickTarget& target) {
  std::sort(ring.order.begin(), ring.order.end());
  for (const auto& [key, s] : ring.order) {
    if (ring.picked[ring_at(s)]) continue;
    if (target.count < target.limit) {
      push_feature(cloud, ring.idx[ring_at(s)], row, target.out, target.indices);
      ++target.count;
    } else if (target.candidate_count < target.candidate_limit) {
      push_feature(cloud, ring.idx[ring_at(s)], row, target.candidates, target.candidate_indices);
      ++target.candidate_count;
    } else {
      break;
    }
    suppress_around(s, settings, ring);
  }
}

/// Selection per sector of the ring: edges first (they suppress plane picks next to them), then planes.
void select_ring_features(const PointCloud& cloud, int num_columns, int row,
                          const LoamFeatureSettings& settings, LoamRing& ring, LoamFeatures& f) {
  const int n = ring.size();
  const auto U = ring_at;
  const std::vector<double>& cosv = ring.cosv;
  int begin = 0;
  for (int sector = 0; sector < settings.num_sectors; ++sector) {
    int end = begin;
    while (end < n && static_cast<long long>(ring.col[U(end)]) * settings.num_sectors / num_columns == sector) {
      ++end;
    }
    LoamSectorCounts& sc = f.sector_counts[U(row * settings.num_sectors + sector)];
    ring.order.clear();
    for (int s = begin; s < end; ++s) {
      if (!std::isnan(cosv[U(s)]) && std::abs(cosv[U(s)]) <= settings.edge_cos_abs_max) {
        ring.order.emplace_back(std::abs(cosv[U(s)]), s);
      }
    }
    pick_in_order(cloud, row, settings, ring,
                  {f.edges, f.edge_indices, sc.num_edges, static_cast<std::size_t>(settings.max_edges_per_sector),
                   f.edge_candidates, f.edge_candidate_indices, sc.num_edge_candidates,
                   static_cast<std::size_t>(settings.max_edge_candidates_per_sector)});
    ring.order.clear();
    for (int s = begin; s < end; ++s) {
      if (!std::isnan(cosv[U(s)]) && cosv[U(s)] <= settings.plane_cos_max) ring.order.emplace_back(cosv[U(s)], s);
    }
    pick_in_order(cloud, row, settings, ring,
                  {f.planes, f.plane_indices, sc.num_planes, static_cast<std::size_t>(settings.max_planes_per_sector),
                   f.plane_candidates, f.plane_candidate_indices, sc.num_plane_candidates,
                   static_cast<std::size_t>(settings.max_plane_candidates_per_sector)});
    begin = end;
  }
}

}  // namespace loam_detail

LoamFeatures extract_loam_features(const PointCloud& cloud, const RangeImage& image,
                                   const LoamFeatureSettings& settings) {
  cloud.check_consistent("extract_loam_features");
  loam_detail::check_feature_settings(settings);
  const std::size_t num_pixels =
      static_cast<std::size_t>(image.num_rows) * static_cast<std::size_t>(image.num_columns);
  PLUMB_CHECK(image.num_rows >= 0 && image.num_columns >= 0 && image.index.size() == num_pixels &&
                  image.range.size() == num_pixels && image.point_row.size() == cloud.size(),
              "extract_loam_features: the range image (" << image.point_row.size()
                  << " points) was not built from this cloud (" << cloud.size() << " points)");

  LoamFeatures f;
  f.num_rings = image.num_rows;
  f.num_sectors = settings.num_sectors;
  f.sector_counts.assign(static_cast<std::size_t>(image.num_rows) * static_cast<std::size_t>(settings.num_sectors),
                         LoamSectorCounts{});
  loam_detail::LoamRing ring;
  for (int row = 0; row < image.num_rows; ++row) {
    loam_detail::gather_ring(cloud, image, row, ring);
    loam_detail::mark_unreliable(settings, ring, f);
    loam_detail::score_ring(cloud, image.num_columns, row, settings, ring, f);
    loam_detail::select_ring_features(cloud, image.num_columns, row, settings, ring, f);
  }
  const bool any = !f.edges.empty() || !f.planes.empty();
  f.status = any ? Status::kOk : Status::kInsufficientData;
  return f;
}

LoamFeatures extract_loam_features(const PointCloud& cloud,
                                   const RangeImageSettings& image_settings,
                                   const LoamFeatureSettings& settings) {
  return extract_loam_features(cloud, build_range_image(cloud, image_settings), settings);
}

}  // namespace plumb
