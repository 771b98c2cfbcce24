// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// @brief The whole initial localization of Liu et al. 2022 (sec. 1) in one call: voxel grid ->
///        normals -> FPFH -> SAC-IA (Huber) -> overlap-gated ICP. Finds a LiDAR frame in the BIM
///        cloud without an initial guess.

#include <cstddef>
#include <memory>

#include <Eigen/Geometry>

#include "plumb/core/point_cloud.hpp"
#include "plumb/core/status.hpp"
#include "plumb/features/fpfh.hpp"
#include "plumb/registration/icp.hpp"
#include "plumb/registration/sac_ia.hpp"
#include "plumb/search/kdtree.hpp"

namespace plumb {

/// @brief Settings of localize_coarse_to_fine(). The coarse stage's lengths scale with `voxel_size`.
struct LocalizeSettings {
  double voxel_size = 0.3;              ///< voxel of the coarse stage (both clouds) [m], > 0
  std::size_t normal_neighbors = 30;    ///< k of the PCA normals (hybrid with radius below), >= 3
  double normal_radius_factor = 2.0;    ///< normal radius = factor * voxel_size
  double fpfh_radius_factor = 5.0;      ///< FPFH radius = factor * voxel_size
  std::size_t fpfh_max_neighbors = 100; ///< FPFH neighbourhood cap (0 = unlimited)
  /// FPFH on the visible side only (FpfhSettings::visible_side_tolerance = factor * voxel_size) for
  /// both clouds, so that a model sampled on every face (both faces of a thin wall, the rooms behind
  /// it) is described as a scan from inside sees it; negative (default) = plain FPFH.
  /// @note Not on by default: on the demo office it does not turn failed localizations into good
  ///       ones; descriptors of a model with hidden faces are much closer to a
  ///       scan's with it (tests/features/fpfh_visible_side_test.cpp).
  double fpfh_visible_side_factor = -1.0;
  /// A target with normals is voxelised per normal direction (six signed axes), so that the two
  /// faces of a wall thinner than a voxel stay two surfaces with their own normals instead of one
  /// voxel whose point and normal come from either face.
  bool split_target_by_normal = false;
  double huber_factor = 1.0;            ///< SAC-IA m1 = factor * voxel_size (replaces sac_ia.huber_threshold)
  double correspondence_factor = 3.0;   ///< SAC-IA truncation = factor * voxel_size (replaces sac_ia.max_correspondence_distance)
  /// SAC-IA; huber_threshold and max_correspondence_distance are replaced as above.
  SacIaSettings sac_ia{};
  /// Voxel of the fine stage for both clouds [m]; 0 = full resolution.
  double fine_voxel_size = 0.1;
  /// ICP of the fine stage: point-to-plane, partial overlap accepted (a LiDAR frame sees clutter the
  /// BIM does not have), Huber kernel.
  IcpSettings icp = [] {
    IcpSettings s;
    s.method = IcpMethod::kPointToPlane;
    s.max_correspondence_distance = 0.6;
    s.distance_step = 0.1;
    s.min_correspondence_distance = 0.1;
    s.min_overlap = 0.5;
    s.overlap_distance = 0.1;
    s.max_iterations = 30;
    s.kernel = RobustKernel::kHuber;
    s.kernel_scale = 0.1;
    return s;
  }();
  /// After the gated ICP, one more ICP round at icp.min_correspondence_distance (no gate) so that
  /// only close surface pairs shape the final estimate; the gate's status is kept.
  bool polish = true;
  /// Keep normals the target already has (a BIM cloud sampled from the model's faces); false
  /// estimates them from the points like the source's.
  bool use_target_normals = true;
  /// Ambiguity test: after the first alignment, SAC-IA + ICP search again for the best alignment
  /// at least ambiguity_distance / ambiguity_angle away from it; when that one's overlap is within
  /// this fraction of the best (>= (1 - margin) * best), the result is kRejected with `ambiguous`
  /// set, since the frame fits two places of the model. The better of the two is returned either
  /// way. Negative (default): no second search (half the time).
  double ambiguity_margin = -1.0;
  double ambiguity_distance = 1.0;      ///< see ambiguity_margin [m]
  double ambiguity_angle = 0.35;        ///< see ambiguity_margin [rad] (20 deg)
  /// Viewpoint of the source's normals, in the source frame (the sensor) [m].
  Vector3f source_viewpoint = Vector3f::Zero();
  /// Threads of the normals, FPFH and ICP stages (0 = every core; replaces `icp.threads`). Results
  /// are bit-identical for any count (core/parallel.hpp).
  int threads = 1;
};

/// @brief Settings with every length scaled to a coarse voxel size v [m] (the defaults are about
///        v = 0.3 m): fine voxel v/3, SAC-IA sample distance 10v/3, ICP from 2v down to v/3,
///        overlap distance and kernel scale v/3.
/// @throws plumb::Error unless v is finite and > 0
LocalizeSettings localize_settings_for_voxel(double v);

/// @brief The target side of localize_coarse_to_fine(), prepared once for many sources (the BIM
///        cloud of a building): voxelised clouds, normals, FPFH and kd-trees.
struct LocalizeTarget {
  PointCloud coarse;                        ///< voxel_size cloud with normals
  std::vector<FpfhSignature> features;      ///< FPFH of `coarse`, parallel to its points
  std::unique_ptr<KdTree3f> coarse_tree;    ///< on coarse.points (null when too few points)
  PointCloud fine;                          ///< fine_voxel_size cloud (normals when the ICP needs them)
  std::unique_ptr<KdTree3f> fine_tree;      ///< on fine.points (null when too few points)
  double seconds = 0.0;                     ///< preparation time [s]
};

/// @brief Result of localize_coarse_to_fine().
struct LocalizeResult {
  Eigen::Isometry3d T_target_source = Eigen::Isometry3d::Identity();  ///< fine estimate
  Status status = Status::kInsufficientData;  ///< the fine stage's status, or the coarse one's if it failed
  bool converged = false;          ///< fine stage met its stopping criterion
  int iterations = 0;              ///< ICP iterations
  std::size_t num_inliers = 0;     ///< ICP correspondences at the result
  double overlap = 0.0;            ///< ICP overlap ratio at the result, [0, 1]
  double rmse = 0.0;               ///< ICP RMS residual [m]
  double degeneracy = 0.0;         ///< see IcpResult::degeneracy
  bool ambiguous = false;          ///< another place fits about as well (see LocalizeSettings::ambiguity_margin)
  double second_overlap = 0.0;     ///< overlap of the best other alignment (0 when none was found)
  Eigen::Isometry3d T_target_source_second = Eigen::Isometry3d::Identity();  ///< that alignment
  SacIaResult coarse;              ///< the SAC-IA stage (of the returned alignment)
  IcpResult fine;                  ///< the ICP stage
  std::size_t num_source_coarse = 0, num_target_coarse = 0;  ///< points in the coarse stage
  double seconds_prepare = 0.0;    ///< voxel + normals + FPFH of the source (and target) [s]
  double seconds_coarse = 0.0;     ///< SAC-IA, both searches [s]
  double seconds_fine = 0.0;       ///< ICP, both searches [s]
};

/// @brief Which parts of a LocalizeTarget prepare_localize_target() builds.
enum class LocalizeStages {
  kCoarseAndFine,  ///< everything localize_coarse_to_fine() needs
  kFineOnly,       ///< only `fine` and `fine_tree`, for refine_localization() (no FPFH: much cheaper)
};

/// @brief Prepare the target side once (see LocalizeTarget).
/// @throws plumb::Error for bad settings or inconsistent cloud fields
LocalizeTarget prepare_localize_target(const PointCloud& target, const LocalizeSettings& settings = {},
                                       LocalizeStages stages = LocalizeStages::kCoarseAndFine);

/// @brief The fine stage of localize_coarse_to_fine() alone, from an initial pose found another
///        way (BimLocalizer's floor-plan search, a user's guess): the source at fine_voxel_size,
///        the overlap-gated ICP (settings.icp) and the polish round.
/// @return the ICP result; kInsufficientData when the target has no fine cloud
/// @throws plumb::Error for bad settings, inconsistent fields or a non-finite initial pose
IcpResult refine_localization(const PointCloud& source, const LocalizeTarget& target,
                              const Eigen::Isometry3d& T_target_source, const LocalizeSettings& settings = {});

/// @brief Liu et al. 2022, sec. 1, in one call against a prepared target; `source` is e.g. the
///        first LiDAR frame.
/// @note Deterministic for a given settings.sac_ia.seed. Empty / tiny / collinear sources return
///       a status (kInsufficientData, kDegenerate...), never throw.
LocalizeResult localize_coarse_to_fine(const PointCloud& source, const LocalizeTarget& target,
                                       const LocalizeSettings& settings = {});

/// @brief Liu et al. 2022, sec. 1, in one call: prepares the target, then localises the source in it.
LocalizeResult localize_coarse_to_fine(const PointCloud& source, const PointCloud& target,
                                       const LocalizeSettings& settings = {});

}  // namespace plumb
