// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief LOAM scan matching (Zhou et al. 2021, sec. 1.3, eq. 6-8): scan-to-scan against the previous frame's
/// features, scan-to-local-map against a feature map, and the point-to-point ICP of the hybrid
/// switch (Zhou et al. 2021, sec. 3.1, eq. 20), all solved by one small Levenberg-Marquardt loop on SE(3).

#include <cstddef>
#include <cstdint>
#include <optional>
#include <vector>

#include <Eigen/Geometry>

#include "plumb/core/error.hpp"
#include "plumb/core/point_cloud.hpp"
#include "plumb/core/status.hpp"
#include "plumb/loam/features.hpp"
#include "plumb/loam/residuals.hpp"
#include "plumb/search/kdtree.hpp"

namespace plumb {

/// @brief Settings of loam_scan_to_scan(), loam_scan_to_map() and loam_icp_scan_to_scan().
struct LoamSettings {
  int max_iterations = 30;  ///< association + LM step rounds, >= 1
  /// A correspondence (nearest feature j, l, m, or map neighbour) farther than this from the
  /// transformed query point is not used [m].
  double max_correspondence_distance = 1.0;
  /// Scan-to-scan: l (edge) and m (plane) are searched on rings r_j +- 1 .. r_j +- ring_window
  /// (LOAM: 2.5 rings), >= 1.
  int ring_window = 2;
  /// Huber kernel scale on the residual norm [m]; 0 = plain least squares.
  double huber_scale = 0.05;
  double min_step_translation = 1e-4;  ///< converged when an accepted step moves less than this [m] ...
  double min_step_rotation = 1e-4;     ///< ... and rotates less than this [rad]
  /// Fewer usable residuals than this at an iteration → Status::kInsufficientData (>= 6).
  std::size_t min_correspondences = 20;
  /// Status::kDegenerate when LoamResult::degeneracy is below this (0 disables the gate).
  double degeneracy_threshold = 0.0;
  double initial_lambda = 1e-4;  ///< LM damping on diag(H) of the first step
  // Scan-to-map only.
  int map_neighbors = 5;             ///< neighbours fitted per query (plane PCA, edge direction), >= 3
  double map_plane_tolerance = 0.2;  ///< every neighbour must be within this of the fitted plane [m]
  double map_edge_ratio = 3.0;       ///< an edge needs largest / second eigenvalue >= this
  /// A plane needs second / smallest eigenvalue >= this: neighbours along one scan line (nearly
  /// collinear, e.g. a ring of ground returns seen from a standing sensor) fix no normal.
  double map_plane_ratio = 10.0;
  /// Threads of the scan-to-map association (0 = every core); its correspondences, and so every
  /// result, are bit-identical for any count (core/parallel.hpp).
  int threads = 1;
};

/// @brief Result of the LOAM scan matchers.
struct LoamResult {
  /// The estimate: maps the current frame into the previous frame (scan-to-scan / ICP target), or
  /// into the map frame (scan-to-map). The guess when nothing could be solved.
  Eigen::Isometry3d T_prev_cur = Eigen::Isometry3d::Identity();
  Status status = Status::kInsufficientData;  ///< kOk: converged (and not degenerate)
  bool converged = false;      ///< an accepted step fell below min_step_* (or no step could lower the cost)
  int iterations = 0;          ///< association + LM rounds run
  std::size_t num_edge = 0;    ///< edge residuals at the last iteration
  std::size_t num_plane = 0;   ///< plane residuals at the last iteration
  std::size_t num_point = 0;   ///< point-to-point residuals at the last iteration (ICP)
  double rmse = 0.0;           ///< RMS residual norm at the last iteration, before its step [m]
  /// Smallest eigenvalue of J^T J / num_residuals at the last iteration (unweighted, translation
  /// [m] and rotation [rad] mixed as in delta). Near 0: a direction the features do not constrain.
  double degeneracy = 0.0;
};

/// @brief One LiDAR residual with its model fixed for a solver step: query point `p` (current
///        frame), anchor `a` (target frame) and the line direction (edge, eq. 6) or plane normal
///        (plane, eq. 7) `dir`; a point-to-point pair (eq. 20) has `dir` zero and `a` the target point.
struct LoamCorrespondence {
  enum class Kind { kEdge, kPlane, kPoint };
  Kind kind = Kind::kPlane;
  Vector3d p = Vector3d::Zero();    ///< query point, current frame [m]
  Vector3d a = Vector3d::Zero();    ///< anchor on the line / plane, or the matched point, target frame [m]
  Vector3d dir = Vector3d::Zero();  ///< unit line direction (edge) or unit normal (plane)
  /// Multiplies the residual (so its square weighs weight^2 in the cost); 1 for a plain LOAM
  /// correspondence. The hybrid's point-to-distribution pairs use it to whiten each axis.
  double weight = 1.0;
};

/// @brief Mean and covariance (about the mean, divided by n) of the points `idx[0..n)` of `cloud`,
///        two passes in double: the neighbourhood model of the map matchers (a line along the
///        largest axis, a plane across the smallest, a Gaussian for point-to-distribution).
/// @pre every index < cloud.size()
/// @throws plumb::Error when n == 0
inline void loam_neighbour_moments(const PointCloud& cloud, const std::size_t* idx, std::size_t n, Vector3d& mean,
                                   Matrix3d& cov) {
  PLUMB_CHECK(n > 0, "loam_neighbour_moments: no point");
  mean.setZero();
  for (std::size_t i = 0; i < n; ++i) mean += cloud.points[idx[i]].cast<double>();
  mean /= static_cast<double>(n);
  cov.setZero();
  for (std::size_t i = 0; i < n; ++i) {
    const Vector3d e = cloud.points[idx[i]].cast<double>() - mean;
    cov += e * e.transpose();
  }
  cov /= static_cast<double>(n);
}

/// @brief A local feature map for scan-to-map matching: edge and plane points in the map frame,
///        each with a kd-tree. Non-finite points are ignored.
class LoamMap {
 public:
  /// @brief Build the trees (either cloud may be empty).
  LoamMap(PointCloud edges, PointCloud planes);
  const PointCloud& edges() const { return edges_; }    ///< @brief Edge points [m], map frame.
  const PointCloud& planes() const { return planes_; }  ///< @brief Plane points [m], map frame.
  /// @brief Edge tree, absent when there is no finite edge point.
  const std::optional<KdTree3f>& edge_tree() const { return edge_tree_; }
  /// @brief Plane tree, absent when there is no finite plane point.
  const std::optional<KdTree3f>& plane_tree() const { return plane_tree_; }

 private:
  PointCloud edges_, planes_;
  std::optional<KdTree3f> edge_tree_, plane_tree_;
};

/// @brief LOAM scan-to-scan (Zhou et al. 2021, eq. 6-8): the current frame's edge and plane points
///        against the previous frame's edge (+candidate) and plane (+candidate) points.
///
/// Each round transforms the queries with the current estimate; an edge query gets its nearest
/// previous edge point j and the nearest edge point l on another ring (eq. 6); a plane query gets
/// its nearest plane point j, the nearest l on j's ring and m on another ring (eq. 7); then one
/// Levenberg-Marquardt step on E_L1 (eq. 8, Huber-weighted) updates `T <- T exp(delta)`.
/// @param prev features of the previous frame (its clouds must carry rings)
/// @param cur features of the current frame
/// @param T_prev_cur_guess initial estimate (e.g. from the IMU or constant velocity)
/// @return the estimate; too few features or correspondences → Status::kInsufficientData
/// @throws plumb::Error on misuse: non-finite guess, bad settings, non-empty feature clouds without rings
/// @note Deterministic; single-threaded (settings.threads is used by the scan-to-map association only); O(iterations * n log m).
LoamResult loam_scan_to_scan(const LoamFeatures& prev, const LoamFeatures& cur,
                             const Eigen::Isometry3d& T_prev_cur_guess,
                             const LoamSettings& settings = {});

/// @brief LOAM scan-to-local-map: all current edge / plane points (incl. candidates) against a
///        feature map; a plane is fitted to `map_neighbors` nearest map plane points (PCA), an edge
///        line along the principal direction of the nearest map edge points.
/// @param T_map_cur_guess initial estimate; the result's T_prev_cur is T_map_cur
LoamResult loam_scan_to_map(const LoamMap& map, const LoamFeatures& cur,
                            const Eigen::Isometry3d& T_map_cur_guess,
                            const LoamSettings& settings = {});

/// @brief The association step of loam_scan_to_map() on its own, for an outside solver (the
///        LiDAR/IMU estimator): the current frame's edges, edge candidates, planes and plane
///        candidates transformed by `T_map_cur`, each matched to a line / plane fitted to its
///        `map_neighbors` nearest map points (only max_correspondence_distance, map_neighbors,
///        map_plane_tolerance and map_edge_ratio of `settings` are used).
/// @param out receives the correspondences (appended)
/// @note Deterministic; const on the map, so several threads may associate against one map.
void loam_associate_map(const LoamMap& map, const LoamFeatures& cur, const Eigen::Isometry3d& T_map_cur,
                        const LoamSettings& settings, std::vector<LoamCorrespondence>& out);

/// @brief What loam_associate_map() keeps between the rounds of one solve (one map, one frame's
///        features, a pose that moves a little each round), so that a round costs less than the first.
///
/// For each query it holds the few nearest map points of the last kd-tree search (more than
/// map_neighbors) with the radius that search covered, and the correspondence last made. A later
/// round checks whether the moved query's map_neighbors nearest points must be among those: when
/// every point beyond the radius is provably farther than the k-th of them (the query moved by
/// less than the margin), they are, and no tree search is made; when they are the same points as
/// last time, the correspondence is the same too and is reused. Otherwise the tree is searched.
/// The correspondences are those of the call without a cache (two different map points at
/// exactly the same float distance from a query may be taken in another order).
/// The cache follows the map and the query clouds it was filled for: another map, or other query
/// clouds, and it starts afresh. Not thread-safe: one cache per solve.
class LoamMapCache {
 public:
  /// @brief Forget everything (a new frame or a new map).
  void clear() { slots_.clear(); }
  /// @brief Queries answered from the cache / by a tree search since the last clear() (statistics).
  std::size_t hits() const;
  std::size_t searches() const;

  /// One query's memory (implementation detail of loam_associate_map()).
  struct Entry {
    Vector3f at = Vector3f::Zero();  ///< where the query was when the tree was last searched
    float radius_sq = -1.0f;         ///< every map point not in `near` is at least this far from `at`; < 0: none
    std::uint8_t num_near = 0;
    std::uint8_t num_used = 0;       ///< neighbours of the last correspondence (0: none made)
    bool has_factor = false;
    std::uint32_t near[16] = {};     ///< map points nearest `at`, ascending by distance
    std::uint32_t used[16] = {};     ///< the neighbours the last correspondence was fitted to
    LoamCorrespondence factor;       ///< the last correspondence, when has_factor
  };
  /// One query cloud's entries against one tree (implementation detail).
  struct Slot {
    const void* queries = nullptr;
    const void* tree = nullptr;
    std::size_t size = 0;
    std::vector<Entry> entries;
    std::size_t hits = 0, searches = 0;
  };
  /// @brief The slot for `queries` against `tree`, made afresh when it held another pair.
  Slot& slot(std::size_t i, const void* queries, const void* tree, std::size_t size);

 private:
  std::vector<Slot> slots_;
};

/// @brief loam_associate_map() that remembers its neighbours in `cache` between the rounds of one
///        solve (see LoamMapCache); the same correspondences.
void loam_associate_map(const LoamMap& map, const LoamFeatures& cur, const Eigen::Isometry3d& T_map_cur,
                        const LoamSettings& settings, std::vector<LoamCorrespondence>& out, LoamMapCache* cache);

/// @brief The association step of loam_icp_scan_to_scan() on its own: each finite point of `cur`
///        transformed by `T_target_cur` paired with its nearest target point within
///        `max_correspondence_distance` [m] (appended to `out`).
void loam_associate_points(const PointCloud& target, const KdTree3f& target_tree, const PointCloud& cur,
                           const Eigen::Isometry3d& T_target_cur, double max_correspondence_distance,
                           std::vector<LoamCorrespondence>& out);

/// @brief Point-to-point ICP (Zhou et al. 2021, eq. 20) with the same solver: each point of `cur` against its
///        nearest point of `prev` within max_correspondence_distance (the hybrid switch's matcher
///        when a frame has too few plane points).
/// @param prev_tree kd-tree built on prev.points
LoamResult loam_icp_scan_to_scan(const PointCloud& prev, const KdTree3f& prev_tree,
                                 const PointCloud& cur, const Eigen::Isometry3d& T_prev_cur_guess,
                                 const LoamSettings& settings = {});

}  // namespace plumb

#include "plumb/loam/impl/odometry_impl.hpp"
