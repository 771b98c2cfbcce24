// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Global 2D correlative scan matching: the pose (x, y, theta) of a set of 2D points in a
///        likelihood grid built from map points, found exhaustively over every heading and every
///        allowed position by branch and bound on a max-pooled grid pyramid (the scheme of
///        Olson, ICRA 2009, and of Cartographer's loop closure; Hess et al., ICRA 2016).
///
/// Used by BimLocalizer to find a robot's first LiDAR frame in the floor plan of a building: unlike
/// descriptor matching (FPFH + SAC-IA), the search cannot miss the best-scoring pose, and it also
/// returns the best pose far from it, so a frame that fits two places equally is recognised.

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <optional>
#include <vector>

#include <Eigen/Geometry>

#include "plumb/core/pose2.hpp"
#include "plumb/core/status.hpp"
#include "plumb/core/types.hpp"

namespace plumb {

/// @brief Settings of CorrelativeMap2D.
struct CorrelativeMapSettings {
  double resolution = 0.05;  ///< cell size and translation step [m], > 0
  /// Likelihood width [m], > 0: a cell at distance d from the nearest map point holds
  /// exp(-d^2 / (2 sigma^2)) (cut to 0 beyond 3 sigma).
  double sigma = 0.1;
  int levels = 8;            ///< pyramid depth: branch windows of 1, 2, 4 ... 2^(levels-1) cells, 1..15
  double margin = 1.0;       ///< grid margin around the map points [m], >= 0
  /// Translations are searched over the map points' box plus margin, grown to cover this box too
  /// (e.g. the free floor: a robot can stand farther than `margin` from every map point, on a
  /// terrace or in a hall). Empty (the default): the map points' box alone.
  Eigen::AlignedBox2d bounds;
  std::size_t max_cells = std::size_t{1} << 26;  ///< larger grids throw (a unit error, a stray point)
  /// With map normals: the likelihood is kept per normal direction in this many sectors, and a scan
  /// point with a normal only meets map points facing the same way (within 1.5 sectors), so a
  /// wall's far face cannot explain a scan of its near face. 0 = ignore normals; else 4..32.
  int orientation_bins = 8;
};

/// @brief Settings of CorrelativeMap2D::match().
struct CorrelativeSearchSettings {
  /// Heading step [rad]; 0 = automatic, acos(1 - r^2 / (2 d^2)) for resolution r and the farthest
  /// scan point d, so that no scan point moves more than one cell between two headings.
  double angular_step = 0.0;
  double angle_center = 0.0;           ///< headings searched: angle_center +- angle_window / 2 [rad]
  double angle_window = 2.0 * 3.14159265358979323846;  ///< full circle by default [rad]
  std::optional<Vector2d> region_center;  ///< only translations within region_radius of this [m]
  double region_radius = 0.0;          ///< [m]; used with region_center
  std::size_t max_points = 1000;       ///< scan points used (deterministic subsample when more)
  std::size_t min_points = 20;         ///< fewer scan points: kInsufficientData
  double min_score = 0.1;              ///< poses scoring less are not returned, [0, 1]
  /// A second search returns the best pose at least this far (translation [m] or heading [rad])
  /// from the best one; negative distance = no second search.
  double second_distance = 1.0;
  double second_angle = 0.35;          ///< [rad]
  /// Optional test of a candidate pose, e.g. free space (see_through()). A pose it rejects is
  /// skipped and the search goes on to the next best, for the best and for the second pose alike.
  /// Called only on single poses that would beat the best found so far.
  std::function<bool(const Pose2&)> accept;
  /// At most this many poses rejected by `accept` per search (best, then second); after that the
  /// search ends with what it has (a frame that fits nowhere must not test every pose). 0 = no limit.
  std::size_t max_rejections = 10000;
  /// Threads of the search (0 = every core). The result (poses, scores, rejections) is the same
  /// for any count; only nodes_scored, the work done, differs. `accept` must then be safe to call
  /// from several threads at once (a const test of the map is).
  int threads = 1;
};

/// @brief Result of CorrelativeMap2D::match().
struct CorrelativeResult {
  /// kOk; kInsufficientData (too few scan points); kRejected (no pose scores min_score).
  Status status = Status::kInsufficientData;
  Pose2 pose;                  ///< map_T_scan: map point = R(theta) scan point + (x, y)
  double score = 0.0;          ///< mean likelihood of the scan points at `pose`, [0, 1]
  bool has_second = false;     ///< a pose outside the exclusion scored at least min_score
  Pose2 second_pose;           ///< best pose far from `pose` (see second_distance)
  double second_score = 0.0;   ///< its score, [0, 1]
  std::size_t num_points = 0;  ///< scan points used
  std::size_t num_angles = 0;  ///< headings searched
  std::size_t nodes_scored = 0;  ///< branch-and-bound nodes scored (both searches; depends on threads)
  std::size_t rejected = 0;    ///< poses CorrelativeSearchSettings::accept turned down (both searches)
  /// A search stopped at CorrelativeSearchSettings::max_rejections: `pose` and `second_pose` are
  /// the best found until then, not necessarily the best there are.
  bool truncated = false;
  double seconds = 0.0;
};

/// @brief Likelihood grid of 2D map points with its branch-and-bound pyramid, and the search.
class CorrelativeMap2D {
 public:
  /// @param map_points   e.g. the walls of one storey [m]; non-finite points are skipped
  /// @param allowed      translations the search may return (e.g. free floor); empty = all of the grid
  /// @param map_normals  empty, or one per map point: the direction its surface faces (unit or not;
  ///                     non-finite = unknown, meets any scan point)
  /// @throws plumb::Error for bad settings, no finite map point, a grid over max_cells, or a
  ///         normal count that differs from the point count
  explicit CorrelativeMap2D(const std::vector<Vector2d>& map_points, const CorrelativeMapSettings& settings = {},
                            const std::function<bool(const Vector2d&)>& allowed = {},
                            const std::vector<Vector2d>& map_normals = {});

  /// @brief Likelihood of the cell holding `p`, [0, 1] (0 outside the grid); with a finite
  ///        `normal`, only map points facing that way count.
  double likelihood(const Vector2d& p, const Vector2d& normal = Vector2d::Constant(std::nan(""))) const;
  /// @brief Mean likelihood of `scan` placed at `pose`, [0, 1] (0 for an empty scan); `normals`
  ///        empty or one per scan point (in the scan frame; non-finite = unknown).
  double score(const std::vector<Vector2d>& scan, const Pose2& pose, const std::vector<Vector2d>& normals = {}) const;
  /// @brief Best pose of `scan` over the search settings' headings and the allowed translations
  ///        (cell corners), and the best pose far from it. `normals`: as in score().
  /// @throws plumb::Error for bad settings or a normal count that differs from the point count
  /// @note Deterministic. The exhaustive search costs about (headings x top-level windows x points)
  ///       lookups plus the branches above the best score.
  CorrelativeResult match(const std::vector<Vector2d>& scan, const CorrelativeSearchSettings& settings = {},
                          const std::vector<Vector2d>& normals = {}) const;

  /// @brief Free-space check of a pose: the fraction of scan points whose ray from `sensor` (scan
  ///        frame) crosses a map cell of likelihood >= 0.5 more than `margin` before the point,
  ///        i.e. that would have been seen through a wall. Near 0 at the true pose (apart from
  ///        openings the map lacks), large at a pose that merely fits some walls.
  double see_through(const std::vector<Vector2d>& scan, const Pose2& pose, const Vector2d& sensor, double margin) const;

  const CorrelativeMapSettings& settings() const { return settings_; }
  Vector2d origin() const { return origin_; }  ///< corner of cell (0, 0) [m]
  int width() const { return width_; }
  int height() const { return height_; }
  std::size_t num_allowed() const { return num_allowed_; }  ///< allowed translation cells

 private:
  struct Level {
    /// Per channel (orientation sector 0..bins-1, then "any direction"): max likelihood (0..255)
    /// over the window at each start; channel c's cells are value[c * cells_ + index(x, y)], one
    /// array so that a scan point's channel and cell are one precomputed step.
    std::vector<std::uint8_t> value;
    std::vector<std::uint8_t> allowed;  ///< 1 when the window holds an allowed translation
  };
  /// One match() call's state and search (defined in correlative.cpp).
  class Matcher;

  // The constructor's stages, in order.
  /// Origin, size and padding of the grid around the finite map points (and settings.bounds).
  void place_grid(const std::vector<Vector2d>& map_points);
  /// Per channel, the grid cells holding a map point.
  std::vector<std::vector<std::uint8_t>> occupied_cells(const std::vector<Vector2d>& map_points,
                                                        const std::vector<Vector2d>& map_normals) const;
  /// Level 0's likelihood: a Gaussian stamp around every occupied cell.
  void stamp_likelihood(const std::vector<std::vector<std::uint8_t>>& occupied);
  /// Level 0's allowed translations.
  void mark_allowed(const std::function<bool(const Vector2d&)>& allowed);
  /// Levels 1.. from level 0.
  void build_pyramid();

  /// Channel of a scan point whose normal (map frame) has angle `phi`; NaN = the any channel.
  int channel_of(double phi) const;
  std::size_t index(int ix, int iy) const {  // ix, iy in [-pad_, width_) x [-pad_, height_)
    return static_cast<std::size_t>(iy + pad_) * static_cast<std::size_t>(stride_) + static_cast<std::size_t>(ix + pad_);
  }
  bool inside(int ix, int iy) const { return ix >= -pad_ && iy >= -pad_ && ix < width_ && iy < height_; }

  CorrelativeMapSettings settings_;
  Vector2d origin_ = Vector2d::Zero();
  int width_ = 0, height_ = 0, pad_ = 0, stride_ = 0;
  std::size_t cells_ = 0;  ///< cells per channel of a level (padding included)
  std::vector<Level> levels_;
  std::size_t num_allowed_ = 0;
  int bins_ = 0;  ///< orientation sectors in use (0 without map normals)
};

}  // namespace plumb
