// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// @brief SAC-IA coarse registration with the Huber score (Liu et al. 2022, sec. 1.2, eq. 2;
///        Rusu et al. 2009).

#include <cstddef>
#include <cstdint>
#include <vector>

#include <Eigen/Geometry>

#include "plumb/core/point_cloud.hpp"
#include "plumb/core/status.hpp"
#include "plumb/features/fpfh.hpp"
#include "plumb/search/kdtree.hpp"

namespace plumb {

/// @brief Settings of align_sac_ia(). Lengths suit indoor scans voxelised to ~0.1-0.3 m; scale
///        them with the voxel size (localize_coarse_to_fine() does).
struct SacIaSettings {
  /// Points per hypothesis (Liu et al. 2022, sec. 1.2, SAC-IA step 1), >= 3.
  std::size_t num_samples = 3;
  double min_sample_distance = 1.0;     ///< d: samples are pairwise farther apart than this [m]
  std::size_t k_correspondences = 5;    ///< a sample's match is drawn among its k most similar target FPFH, >= 1
  /// How a sample's match is drawn among its k candidates. Off: uniformly (Rusu et al. 2009).
  /// On: candidate m with probability proportional to exp(-(f_m^2 - f_1^2) / (2 f_1^2)), f being
  /// the feature distance and f_1 the closest one. A match much more similar than the others is
  /// drawn almost every time; candidates about equally similar are drawn about uniformly. The
  /// draw stays random among the k, so a wrong closest match does not lock the search.
  bool similarity_weighted = true;
  int max_iterations = 20000;           ///< hypotheses drawn at most, >= 1
  double huber_threshold = 0.3;         ///< m1 of the Huber penalty (Liu et al. 2022, eq. 2) [m]
  /// m1 is also the largest residual a sample pair may keep under its own hypothesis (a cheap
  /// check before scoring). Nearest distances are truncated at max_correspondence_distance in the
  /// score (a point without a target neighbour this close costs H(max_correspondence_distance)) [m];
  /// >= huber_threshold.
  double max_correspondence_distance = 1.0;
  /// Pre-rejection: every edge of the sampled polygon must satisfy min(|p_a p_b|, |q_a q_b|) /
  /// max(...) >= this (rigid motions keep lengths). 0 disables it. In [0, 1).
  double edge_similarity = 0.9;
  /// Early termination: stop once the probability of having drawn an all-correct sample set,
  /// estimated from the best hypothesis, reaches this. 1 runs all max_iterations. In (0, 1].
  double confidence = 0.999;
  /// Keep a candidate pair (source i, target j) only when i is also among the k most similar
  /// source signatures of j. Fewer, cleaner candidates; points left without one are not sampled.
  bool mutual_filter = false;
  /// Pre-scoring: a hypothesis is first scored on this many source points (a fixed random
  /// subset) and fully scored only when that partial Huber total is at most
  /// (1 + prescore_slack) times the best hypothesis's total on the same points. 0 scores every
  /// surviving hypothesis fully (the exact early exit still applies).
  std::size_t num_prescore_points = 100;
  double prescore_slack = 0.1;          ///< see num_prescore_points, >= 0
  std::uint64_t seed = 42;              ///< the only source of randomness
  /// Hypotheses closer than exclude_distance [m] (translation) and exclude_angle [rad] (rotation)
  /// to one of these poses are skipped: a second search for the best *other* alignment, to tell
  /// whether the first one is unique (localize_coarse_to_fine's ambiguity test).
  std::vector<Eigen::Isometry3d> excluded;
  double exclude_distance = 1.0;        ///< see `excluded` [m]
  double exclude_angle = 0.35;          ///< see `excluded` [rad] (20 deg)
  /// Rough position hint: when region_radius > 0, only hypotheses that put the source origin (the
  /// sensor) within region_radius of region_center (in the target frame, horizontal distance) are
  /// scored. An operator who knows the room the robot starts in turns a building of look-alike
  /// rooms into one candidate.
  Eigen::Vector3d region_center = Eigen::Vector3d::Zero();
  double region_radius = 0.0;           ///< [m]; 0 = anywhere
};

/// @brief Result of align_sac_ia().
struct SacIaResult {
  Eigen::Isometry3d T_target_source = Eigen::Isometry3d::Identity();  ///< best hypothesis (identity if none)
  Status status = Status::kInsufficientData;  ///< kOk when terminated by confidence; kNotConverged at
                                              ///< the iteration limit (the best hypothesis is still returned)
  bool converged = false;       ///< early termination by confidence
  int iterations = 0;           ///< hypotheses drawn
  int num_scored = 0;           ///< hypotheses that passed pre-rejection and were (pre-)scored
  int num_fully_scored = 0;     ///< hypotheses that passed the pre-scoring as well
  std::size_t num_feature_queries = 0;  ///< source points whose feature neighbours were computed
  std::size_t num_inliers = 0;  ///< source points within huber_threshold of the target under the result
  double overlap = 0.0;         ///< num_inliers / finite source points, [0, 1]
  double rmse = 0.0;            ///< RMS nearest distance of the inliers [m]
  double score = 0.0;           ///< sum of Huber penalties (Liu et al. 2022, eq. 2) of the best hypothesis
};

/// @brief SAC-IA (Liu et al. 2022, sec. 1.2): draw samples farther apart than d, give each a random
///        one of its k most similar target features, solve the transform in closed form (Horn),
///        score it by the Huber penalty of every transformed source point's nearest-target
///        distance, keep the best.
///
/// What makes it fast, without changing the sampling or scoring of Liu et al. 2022:
/// - feature neighbours come from an exact kd-tree over the target signatures and are computed
///   only for source points that get sampled (then cached), optionally mutually filtered;
/// - cheap pre-rejection: edge-length similarity of the sampled polygon, then every sample pair
///   must lie within huber_threshold under its own hypothesis;
/// - pre-scoring on a fixed random subset of the source before the full score, and an exact early
///   exit of the full score once its partial sum exceeds the best;
/// - early termination (RANSAC-style) once an all-correct sample set has been drawn with the
///   requested confidence, the inlier ratio being the share of computed (point, candidate) pairs
///   that the best hypothesis maps within huber_threshold.
/// @param source, target clouds; `*_features[i]` describes point i (compute_fpfh() on the whole
///        cloud). All-zero (invalid) signatures and non-finite points are never sampled or matched.
/// @param target_tree kd-tree on `target.points`
/// @throws plumb::Error for mismatched sizes, a tree of another cloud or bad settings
/// @note Deterministic for a given `settings.seed`; single thread. Cost: a kd-tree over the target
///       signatures, one feature kNN per sampled source point, O(iterations) cheap checks, and
///       O(num_prescore_points log m) per scored / O(n log m) per fully scored hypothesis.
SacIaResult align_sac_ia(const PointCloud& source, const std::vector<FpfhSignature>& source_features,
                         const PointCloud& target, const std::vector<FpfhSignature>& target_features,
                         const KdTree3f& target_tree, const SacIaSettings& settings = {});

}  // namespace plumb
