// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Plane model and RANSAC plane fitting with an optional axis constraint (Liu et al. 2022,
///        sec. 2.2, eq. 10-11): deterministic from a seed, early stop by confidence, least-squares refit.

#include <cstddef>
#include <cstdint>
#include <vector>

#include "plumb/core/status.hpp"
#include "plumb/core/types.hpp"

namespace plumb {

/// @brief Plane `A x + B y + C z = D` with `(A, B, C) = normal`, `|normal| = 1` and `D = offset`
///        (Liu et al. 2022, eq. 10).
struct Plane {
  Vector3d normal = Vector3d::UnitZ();  ///< unit normal (A, B, C)
  double offset = 0.0;                  ///< D [m]; |D| is the plane's distance from the origin

  /// @brief Signed distance `n.p - D` of a point [m] (positive on the side the normal points to).
  double signed_distance(const Vector3d& p) const { return normal.dot(p) - offset; }
  /// @brief signed_distance() of a float point.
  double signed_distance(const Vector3f& p) const { return signed_distance(Vector3d(p.cast<double>())); }
};

/// @brief Orientation a plane must have relative to an axis.
enum class AxisConstraint {
  kNone,           ///< any plane
  kPerpendicular,  ///< plane perpendicular to the axis: normal within ε of ±axis (floor to z)
  kParallel,       ///< plane parallel to the axis: normal within ε of a direction ⊥ axis (wall to z)
};

/// @brief How fit_plane_ransac() draws a plane hypothesis.
enum class PlaneSampling {
  kThreePoints,  ///< the plane through 3 distinct candidates (classic minimal sample)
  /// The plane through one candidate with that candidate's normal (needs normals): a minimal sample
  /// of one, so far fewer draws when the plane holds a small share of the candidates (several
  /// walls); the least-squares refit removes the normal's noise.
  kPointNormal,
};

/// @brief Settings of fit_plane_ransac().
struct PlaneRansacSettings {
  double distance_threshold = 0.05;  ///< τ of eq. 11: inlier when |n.p - D| < τ [m], > 0
  int max_iterations = 1000;         ///< samples drawn at most (rejected samples count), >= 1
  /// Stop once the probability that a better all-inlier sample was missed is below 1 - confidence,
  /// i.e. after log(1 - confidence) / log(1 - w^s) samples (s = 3 or 1 points per sample) for the best inlier fraction w so far;
  /// >= 1 disables the early stop. In [0, 1].
  double confidence = 0.99;
  PlaneSampling sampling = PlaneSampling::kThreePoints;  ///< see PlaneSampling
  AxisConstraint constraint = AxisConstraint::kNone;  ///< see AxisConstraint
  Vector3d axis = Vector3d::UnitZ();                  ///< constraint axis, non-zero
  double max_axis_angle = 0.17453292519943295;        ///< ε of the constraint [rad] (10 deg)
  /// When normals are given, an inlier's normal must also lie within this angle of the plane's
  /// normal (as lines, sign ignored) [rad]; >= pi/2 accepts any normal.
  double max_normal_angle = 0.5235987755982988;  ///< (30 deg)
  std::size_t min_inliers = 3;  ///< fewer inliers -> Status::kInsufficientData, >= 3
  bool refine = true;           ///< least-squares refit on the inliers, then one re-count
  std::uint64_t seed = 42;      ///< the only source of randomness
};

/// @brief Result of fit_plane_ransac().
struct PlaneRansacResult {
  Plane plane;  ///< the model (meaningful when status is kOk)
  /// Indices (into the `points` given) of the inliers among the candidates, ascending.
  std::vector<std::size_t> inliers;
  Status status = Status::kInsufficientData;  ///< kOk, kInsufficientData (too few candidates or
                                              ///< inliers) or kDegenerate (no valid sample)
  bool converged = false;       ///< early stop reached before max_iterations
  int iterations = 0;           ///< samples drawn
  std::size_t num_candidates = 0;  ///< finite candidates searched
  double rmse = 0.0;            ///< RMS point-to-plane distance of the inliers [m]
};

/// @brief RANSAC plane among `candidates` (Liu et al. 2022, eq. 10-11): draw 3 distinct candidates (or one
///        with its normal, see PlaneSampling), reject collinear samples and samples that violate the axis constraint, score by inlier count
///        (|n.p - D| < τ, and normal agreement when `normals` is given), keep the best
///        (first best on ties), stop early by confidence, then refit by least squares.
/// @param points     the points [m] (float; solved in double)
/// @param candidates indices into `points` to search; empty = every point
/// @param normals    empty, or one normal per point (NaN normals never agree)
/// @param settings   see PlaneRansacSettings
/// @return the plane with its normal oriented toward the origin (the sensor), i.e. D <= 0; for a
///         plane through the origin, with `normal . axis >= 0`
/// @throws plumb::Error on invalid settings, an index out of range, normals of the wrong size, or
///         kPointNormal sampling without normals
/// @note Deterministic for a given seed (Rng is mt19937_64, sampling by hand). O(iterations *
///       candidates), one thread, no shared state.
PlaneRansacResult fit_plane_ransac(const std::vector<Vector3f>& points,
                                   const std::vector<std::size_t>& candidates,
                                   const std::vector<Vector3f>& normals,
                                   const PlaneRansacSettings& settings = {});

/// @brief Least-squares plane (total least squares: PCA of the points, in double) through
///        `points[indices]` (all points when `indices` is empty; non-finite points skipped).
/// @param rmse if not null, receives the RMS distance of the points to the plane [m]
/// @return false when fewer than 3 finite points or they are collinear
bool fit_plane_least_squares(const std::vector<Vector3f>& points, const std::vector<std::size_t>& indices,
                             Plane& plane, double* rmse = nullptr);

}  // namespace plumb
