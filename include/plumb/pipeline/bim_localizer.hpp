// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief BimLocalizer (Liu et al. 2022, sec. 1): where is the robot in the building, from its
///        first LiDAR frame alone?
///
/// Liu et al. 2022 (sec. 1.2-1.3) find the frame in the BIM cloud with FPFH + SAC-IA, then the
/// overlap-gated ICP. In an office (rooms alike, thin walls, furniture the model does not have) the
/// FPFH matches between model and scan are mostly wrong: on the demo office SAC-IA found none of
/// eight random starts.
/// A ground robot stands on a floor with its base level, so the unknowns that matter are
/// (storey, x, y, heading). BimLocalizer therefore:
///  1. per walkable storey, builds a likelihood grid of the model's vertical faces between
///     slice_min and slice_max above the floor, with the storey's free floor as the allowed
///     positions (CorrelativeMap2D);
///  2. projects the frame's points in the same height band (in the base frame) to 2D and searches
///     every storey, heading and free position exhaustively by branch and bound;
///  3. refines the best pose in 3D against the BIM cloud with the overlap-gated ICP of Liu et al.
///     2022, sec. 1.3 (refine_localization());
///  4. gates: a score too low (the frame is not from this building), a second place scoring
///     almost as well (ambiguous: give a start hint), or an ICP that fails or moves far.
///
/// A single frame cannot tell look-alike rooms or mirrored flats apart; a robot that drives a few
/// metres can. localize() therefore also takes several frames with their motion relative to the
/// first (LocalizerView, e.g. the front end's chained scan matches): their band points together
/// form one wider 2D scan, searched as above; the 3D refinement uses all of them; the result is the
/// first frame's pose. The search stays exhaustive, so unlike a filter over the first frame's best
/// few places it cannot lose the true place because the first frame scored it low (furniture, a
/// person in front of the LiDAR).

#include <cstddef>
#include <memory>
#include <optional>
#include <vector>

#include <Eigen/Geometry>

#include "plumb/bim/mesh.hpp"
#include "plumb/core/point_cloud.hpp"
#include "plumb/core/status.hpp"
#include "plumb/registration/localize.hpp"
#include "plumb/scan2d/correlative.hpp"

namespace plumb {

/// @brief Settings of BimLocalizer.
struct BimLocalizerSettings {
  /// Per-storey likelihood grids: 10 cm cells (the ICP refines), sigma 10 cm, 6.4 m top windows.
  CorrelativeMapSettings map = [] {
    CorrelativeMapSettings m;
    m.resolution = 0.1;
    m.sigma = 0.1;
    m.levels = 7;
    return m;
  }();
  double slice_min = 0.3;          ///< height band above the floor used, model and frame [m]
  double slice_max = 2.2;          ///< [m]
  double max_normal_z = 0.5;       ///< model points count as vertical faces when |n_z| <= this
  double max_range = 30.0;         ///< frame points farther from the LiDAR are not used [m]
  std::size_t max_points = 500;    ///< frame points in the search (thinned evenly)
  int storey = -1;                 ///< BimMesh::storeys index to search; -1 = every walkable storey
  double min_walkable_area = 4.0;  ///< storeys with less free floor are skipped [m^2]
  /// Gate: mean likelihood of the frame's points at the best pose, [0, 1]. Frames from another
  /// building score lower (measured in tests/pipeline/bim_localizer_test.cpp).
  double min_score = 0.45;
  /// With a start hint, a pose scoring at least min_score_hinted (but below min_score) is accepted
  /// when its 3D ICP overlap reaches min_overlap_hinted: in open space (a terrace, a hall) few
  /// walls fall in the height band and the 2D score stays low, but the whole frame agrees with the
  /// model. Measured: such true starts reach overlaps of 0.68-0.72, frames from another building
  /// at most 0.49, and true places the ICP leaves 0.23 m off along a weak direction 0.60.
  double min_score_hinted = 0.40;
  double min_overlap_hinted = 0.65;
  /// Gate: a pose at least ambiguity_distance / ambiguity_angle from the best one scoring
  /// >= (1 - ambiguity_margin) * best makes the result kRejected with `ambiguous` set.
  double ambiguity_margin = 0.05;
  double ambiguity_distance = 1.0; ///< [m]
  double ambiguity_angle = 0.35;   ///< [rad]
  /// When the 2D scores are that close, both poses are refined in 3D and the one whose ICP overlap
  /// is higher by at least this much wins (ceiling heights, sills, stairs tell storeys and mirror
  /// images apart); otherwise the result is ambiguous.
  double ambiguity_overlap_margin = 0.05;
  /// When the 3D overlap had to decide between two places, the winner's 2D score must reach this
  /// too (a weak 2D match decided by overlap put the robot 25 m off on a duplex terrace); else
  /// the result is ambiguous.
  double min_score_when_ambiguous = 0.5;
  /// Fine stage (refine_localization): BIM cloud and frame at fine_voxel_size, point-to-plane ICP;
  /// localize_settings_for_voxel(0.15) (ICP from 0.3 m down to 0.05 m, fine voxel 0.05 m) with up
  /// to 50 iterations per round.
  LocalizeSettings fine = [] {
    LocalizeSettings s = localize_settings_for_voxel(0.15);
    s.icp.max_iterations = 50;
    return s;
  }();
  double max_refine_shift = 0.5;   ///< gate: ICP moving the base farther than this from the 2D pose [m]
  /// On a storey whose floor the model does not hold (its floor plan comes from the walls,
  /// bim::FloorSource::kWalls), the frame's points lower than this above the base (the floor it
  /// sees) are left out of the 3D refinement and its overlap: the model cannot explain them [m].
  double unmodelled_floor_height = 0.15;
  /// Before a hinted weak match (score in [min_score_hinted, min_score)) is rejected because its 3D
  /// overlap is below min_overlap_hinted, the refinement is run again from the 2D pose shifted by
  /// +-retry_shift along the direction the frame's walls (height band) constrain least; the start
  /// whose result has the highest overlap wins (its shift from the 2D pose is still gated by
  /// max_refine_shift). Along such a direction the 2D optimum and the ICP can both settle next to
  /// the true pose (measured on the duplex: 0.24 m off at overlap 0.60, where the true pose
  /// reaches 0.66). 0 = no retry. [m]
  double retry_shift = 0.25;
  /// Gate: at most this fraction of the frame's points (height band) may lie behind a model wall
  /// that is solid over the whole band (no door or window there), as seen from the LiDAR, more
  /// than see_through_margin beyond it (CorrelativeMap2D::see_through).
  double max_see_through = 0.17;
  double see_through_margin = 1.0;  ///< [m] (large enough that rays grazing a wall do not count)
  /// The 2D search skips poses seeing through more than this fraction (tested on up to 200 of the
  /// points, at the search's pose) and goes on to the next best: a place that scores well only by
  /// looking through walls neither wins nor makes the result ambiguous. 0 = no test in the search.
  double search_see_through = 0.17;
  /// Threads of the 2D search and of the 3D refinement (0 = every core); the result is the same for
  /// any count (BimLocalization::nodes_scored, the work done, aside). `fine.threads` is overridden.
  int threads = 1;
};

/// @brief Result of BimLocalizer::localize().
struct BimLocalization {
  /// kOk; kInsufficientData (too few frame points in the band); kRejected (score gate, ambiguous,
  /// ICP moved too far, or nothing found in the hint region); the ICP's status when it failed.
  Status status = Status::kInsufficientData;
  Eigen::Isometry3d T_world_base = Eigen::Isometry3d::Identity();  ///< refined base pose in the BIM frame
  Eigen::Isometry3d T_world_base_search = Eigen::Isometry3d::Identity();  ///< the 2D search's pose (floor height)
  int storey = -1;                 ///< BimMesh::storeys index of the pose
  double score = 0.0;              ///< 2D score of the best pose, [0, 1]
  double second_score = 0.0;       ///< best score away from it (any storey), [0, 1]
  Eigen::Isometry3d T_world_base_second = Eigen::Isometry3d::Identity();  ///< that pose
  bool ambiguous = false;          ///< see BimLocalizerSettings::ambiguity_margin
  double second_overlap = -1.0;    ///< 3D overlap at the second pose (-1: not refined, scores far apart)
  double see_through = 0.0;        ///< frame points seen through model walls at the result, [0, 1]
  std::size_t rejected_by_free_space = 0;  ///< search poses skipped by search_see_through
  /// The search gave up after CorrelativeSearchSettings::max_rejections poses seeing through
  /// walls (the frame fits nowhere well): the result is kRejected.
  bool truncated = false;
  IcpResult fine;                  ///< the 3D refinement (overlap, rmse, degeneracy)
  int refine_starts = 0;           ///< 3D refinements of the result (1, or 3 with the retry)
  std::size_t num_points = 0;      ///< frame points in the 2D search
  std::size_t views = 0;           ///< frames the result was found from (LocalizerView)
  std::size_t nodes_scored = 0;    ///< branch-and-bound nodes over all storeys
  double seconds_search = 0.0, seconds_fine = 0.0;
};

/// @brief One frame of a localization from several frames (BimLocalizer::localize()).
struct LocalizerView {
  const PointCloud* frame = nullptr;  ///< LiDAR frame (deskewed), not owned
  /// The base at this frame in the base frame of the first view (level motion: z, roll and pitch
  /// are ignored), e.g. the front end's chained motion. Identity for the first view.
  Eigen::Isometry3d T_base0_base = Eigen::Isometry3d::Identity();
};

/// @brief Finds LiDAR frames in a building (see the file comment). Build once per model.
class BimLocalizer {
 public:
  /// @param mesh       the building (storeys, floor plans)
  /// @param bim_cloud  the model's surfaces with normals, e.g. sample_bim_cloud(mesh, 0.05)
  /// @throws plumb::Error for bad settings, a mesh without walkable storey, or a cloud without normals
  BimLocalizer(const bim::BimMesh& mesh, const PointCloud& bim_cloud, const BimLocalizerSettings& settings = {});

  /// @brief Localize one frame (LiDAR frame, deskewed if the robot moved), base assumed level.
  /// @param hint  rough base position (x, y in the BIM frame): only poses within hint_radius count
  /// @throws plumb::Error for inconsistent cloud fields, a non-finite extrinsic or a bad hint
  BimLocalization localize(const PointCloud& frame, const Eigen::Isometry3d& T_base_lidar,
                           const std::optional<Vector2d>& hint = std::nullopt, double hint_radius = 3.0) const;

  /// @brief Localize the first of several frames from all of them (see the file comment): the
  ///        result's poses are those of views[0]'s base. One view gives the result of the
  ///        single-frame localize() bit for bit. The drift of the views' relative motion should stay
  ///        well under the grid resolution (10 cm): a front end over some metres, not wheel odometry
  ///        over a long drive.
  /// @throws plumb::Error for no view, a null or inconsistent frame, a non-finite motion or
  ///         extrinsic, or a bad hint
  BimLocalization localize(const std::vector<LocalizerView>& views, const Eigen::Isometry3d& T_base_lidar,
                           const std::optional<Vector2d>& hint = std::nullopt, double hint_radius = 3.0) const;

  /// @brief Storeys searched (BimMesh::storeys indices) and their floor heights.
  std::vector<int> storeys() const;
  const BimLocalizerSettings& settings() const { return settings_; }
  double seconds_prepare() const { return seconds_prepare_; }  ///< constructor time [s]

 private:
  struct StoreyMap {
    int index = -1;
    double floor_z = 0.0;
    bool floor_modelled = true;  ///< false: the floor plan came from the walls (no floor surfaces)
    std::unique_ptr<CorrelativeMap2D> map;
    /// Walls that are solid over the whole height band (no door or window in the column): what a
    /// ray at any height cannot pass, for the see-through gate.
    std::unique_ptr<CorrelativeMap2D> solid;
  };
  /// The 2D search's outcome over all storeys.
  struct StoreySearch {
    double best = -1.0, second = 0.0;  ///< scores of the best pose and of the best one away from it
    const StoreyMap* best_map = nullptr;
    const StoreyMap* second_map = nullptr;
    Pose2 best_pose, second_pose;
    bool any_data = false;   ///< some storey had enough points to search
    bool truncated = false;  ///< some storey's search gave up on poses seeing through walls
  };
  /// The views' points in the height band, in the first view's base frame, one per map cell, with
  /// their normals and the sensor position they were seen from.
  struct BandScan {
    std::vector<Vector2d> points, normals;
    std::vector<std::size_t> view;  ///< the view each point comes from
    std::vector<Vector2d> sensors;  ///< per view, in the first view's base frame
  };
  /// Searches every storey's map for the band points (counts go into `out`).
  StoreySearch search_storeys(const BandScan& scan, const std::optional<Vector2d>& hint, double hint_radius,
                              BimLocalization& out) const;
  /// Refines out.T_world_base_search in 3D into out.fine, and the second pose too when `close_scores`
  /// (the higher overlap wins); returns the frame the result was refined with (`frame`, or it
  /// without its floor points, kept in `without_floor`).
  const PointCloud* refine_found(const PointCloud& frame, const Eigen::Isometry3d& T_base_lidar,
                                 const StoreySearch& found, bool close_scores, PointCloud& without_floor,
                                 BimLocalization& out) const;
  /// Refines again from the 2D pose shifted by +-retry_shift along the direction the walls
  /// constrain least, keeping a better result (settings_.retry_shift).
  void retry_refinement(const PointCloud& result_frame, const Eigen::Isometry3d& T_base_lidar,
                        const std::vector<Vector2d>& normals, BimLocalization& out) const;
  /// Sets out.see_through, out.truncated and out.status from the gates of BimLocalizerSettings.
  void apply_gates(const BandScan& scan, const StoreySearch& found, bool hinted_weak, BimLocalization& out) const;

  BimLocalizerSettings settings_;
  std::vector<StoreyMap> maps_;
  LocalizeTarget fine_;
  double seconds_prepare_ = 0.0;
};

}  // namespace plumb
