// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Cosine-angle edge / plane features on a range image (Zhou et al. 2021, sec. 1.2, eq. 5),
/// selected per ring and azimuth sector as in LOAM / LeGO-LOAM.

#include <cstddef>
#include <vector>

#include "plumb/core/point_cloud.hpp"
#include "plumb/core/status.hpp"
#include "plumb/loam/range_image.hpp"

namespace plumb {

/// @brief Settings of extract_loam_features().
struct LoamFeatureSettings {
  /// Plane points: cos(theta_i) in [-1, plane_cos_max] (angle 170..190 deg, Zhou et al. 2021, sec. 1.2).
  double plane_cos_max = -0.984;
  /// Edge points: cos(theta_i) in [-edge_cos_abs_max, edge_cos_abs_max] (angle 80..100 deg).
  double edge_cos_abs_max = 0.174;
  int num_sectors = 6;                         ///< azimuth sectors per ring (equal column ranges), >= 1
  int max_planes_per_sector = 4;               ///< plane points per ring and sector (cos nearest -1)
  int max_plane_candidates_per_sector = 4;     ///< next best plane points per ring and sector
  int max_edges_per_sector = 2;                ///< edge points per ring and sector (cos nearest 0)
  int max_edge_candidates_per_sector = 2;      ///< next best edge points per ring and sector
  /// The neighbours i-1, i+1 of eq. 5 are the points `neighbor_offset` places before and after i
  /// along the ring (1 = the immediate neighbours of Zhou et al. 2021, eq. 5). A larger offset
  /// widens the baseline so that range noise does not swamp the angle on dense near-field rings.
  int neighbor_offset = 3;
  /// A neighbour more than this many columns away from i (a gap in the ring) leaves i unscored.
  int max_neighbor_column_gap = 12;
  /// Occlusion (LOAM): where the range jumps by more than this between two adjacent points of a
  /// ring, the `occlusion_span` points on the far side of the jump are not used [m].
  double occlusion_range_jump = 0.3;
  int occlusion_span = 5;                      ///< see occlusion_range_jump
  /// Parallel beam (LOAM): a point whose range differs from both adjacent points by more than this
  /// fraction of its own range lies on a surface nearly parallel to the beam and is not used.
  double parallel_beam_ratio = 0.02;
  /// After a point is selected, points up to this many places away on its ring (and no farther
  /// than max_neighbor_column_gap columns per place) are not selected, so features spread out.
  int suppression_radius = 5;
  /// The plane pool (see LoamFeatures::plane_pool) keeps every `plane_pool_stride`-th point of
  /// the plane interval along each ring (1 = all), >= 1.
  int plane_pool_stride = 2;
};

/// @brief Counts of one ring sector.
struct LoamSectorCounts {
  std::size_t num_scored = 0;          ///< points with a cos(theta) (usable, with both neighbours)
  std::size_t num_plane_interval = 0;  ///< scored points whose cos is in the plane interval
  std::size_t num_edge_interval = 0;   ///< scored points whose cos is in the edge interval
  std::size_t num_planes = 0;          ///< plane points selected
  std::size_t num_plane_candidates = 0;
  std::size_t num_edges = 0;           ///< edge points selected
  std::size_t num_edge_candidates = 0;
};

/// @brief Features of one frame. Every cloud carries `rings` (its range-image row) and, when the
/// input had them, `times`; the `*_indices` vectors give each feature's index in the input cloud.
struct LoamFeatures {
  PointCloud edges;             ///< edge points (cos nearest 0): queries of scan matching
  PointCloud edge_candidates;   ///< next best edge points; edges + candidates = the "less sharp" set
  PointCloud planes;            ///< plane points (cos nearest -1): queries of scan matching
  PointCloud plane_candidates;  ///< next best plane points; planes + candidates = the "less flat" set
  /// Every usable point whose cos is in the edge interval (LOAM's "less sharp" set): the
  /// previous frame's side of scan-to-scan edge association.
  PointCloud edge_pool;
  /// Every `plane_pool_stride`-th usable point in the plane interval along each ring (LOAM's "less
  /// flat" set): the previous frame's side of plane association, dense enough that j, l, m of
  /// eq. 7 lie on one surface.
  PointCloud plane_pool;
  std::vector<std::size_t> edge_indices, edge_candidate_indices;
  std::vector<std::size_t> plane_indices, plane_candidate_indices;
  int num_rings = 0;    ///< rows of the range image
  int num_sectors = 0;  ///< sectors per ring
  /// Per ring and sector, ring-major: `sector_counts[ring * num_sectors + sector]`.
  std::vector<LoamSectorCounts> sector_counts;
  /// Frame totals of the cos intervals (Zhou et al. 2021, sec. 1.2: how structured the scene is).
  std::size_t num_plane_interval = 0;
  std::size_t num_edge_interval = 0;
  std::size_t num_scored = 0;    ///< points with a cos value
  std::size_t num_occluded = 0;  ///< points excluded as occluded
  std::size_t num_parallel = 0;  ///< points excluded as parallel-beam
  /// kOk when at least one plane or edge point was selected, else kInsufficientData.
  Status status = Status::kInsufficientData;
};

/// @brief cos(theta_i) of Zhou et al. 2021, eq. 5, from the three points (law of cosines on the distances).
/// @return the cosine in [-1, 1], or NaN when two of the points coincide
double loam_cosine(const Vector3d& prev, const Vector3d& point, const Vector3d& next);

/// @brief Score every point of every ring with eq. 5, drop occluded and parallel-beam points,
///        count the cos intervals and select edge / plane points per ring and sector.
/// @param cloud the frame the image was built from
/// @param image build_range_image(cloud, ...)
/// @throws plumb::Error on misuse: an image not built from this cloud, bad settings
/// @note O(n log n); deterministic (ties by column); no shared state.
LoamFeatures extract_loam_features(const PointCloud& cloud, const RangeImage& image,
                                   const LoamFeatureSettings& settings = {});

/// @brief build_range_image() then extract_loam_features().
LoamFeatures extract_loam_features(const PointCloud& cloud,
                                   const RangeImageSettings& image_settings,
                                   const LoamFeatureSettings& settings = {});

}  // namespace plumb
