// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Normal / projection pre-segmentation (Liu et al. 2022, sec. 2.2, eq. 8, 9 and 12):
///        per-point angles of the normal to an axis and projection lengths, and the candidate
///        selection by thresholds that shrinks the point set a plane RANSAC has to search.

#include <cstddef>
#include <limits>
#include <vector>

#include "plumb/core/types.hpp"

namespace plumb {

/// @brief Angle between a normal and an axis, `theta = arccos(n.k / (|n||k|))` (Liu et al. 2022, eq. 8).
/// @return the angle in [0, pi] [rad]; NaN when either vector is zero or not finite.
/// @note Signed: with normals oriented toward the sensor, a floor below it gives ~0 to +z and a
///       ceiling ~pi.
double normal_axis_angle(const Vector3f& n, const Vector3d& axis);


/// @brief Projection length of a point onto its own normal, `l = |n . Oq| / |n|` (Liu et al. 2022, eq. 9):
///        the distance from the sensor origin O of the plane through q with normal n.
/// @return l >= 0 [m]; NaN when n is zero or not finite.
double projection_length(const Vector3f& q, const Vector3f& n);

/// @brief Vertical-plane indicator of Liu et al. 2022, eq. 12: `u1 = n x i`, `u2 = n x j`; the angle between
///        u and the z axis, which is ~0 when n is horizontal (the point lies on a vertical plane).
/// @return the angle between the line of u and z, in [0, pi/2] [rad]; NaN for a zero/NaN normal.
/// @note The paper takes u1 unless it is zero; here the longer of u1, u2 is taken, which is the
///       same choice away from the degenerate case and stays well conditioned when n is close to
///       i (then u1 is short and its direction is noise). With n = (a, b, c) the result is
///       atan(|c| / max(|a|, |b|)).
double vertical_u_angle(const Vector3f& n);

/// @brief Which angle pre-segment() thresholds.
enum class PresegmentAngle {
  kNormalToAxis,  ///< eq. 8: angle between the (oriented) normal and `axis`, in [0, pi]
  kVerticalU,     ///< eq. 12: angle between u = n x i (or n x j) and z, in [0, pi/2]; `axis` unused
};

/// @brief Thresholds of presegment(): a point is a candidate when its angle lies in
///        [min_angle, max_angle] and its projection length l in [min_length, max_length].
struct PresegmentSettings {
  PresegmentAngle angle_kind = PresegmentAngle::kNormalToAxis;  ///< which angle, see PresegmentAngle
  Vector3d axis = Vector3d::UnitZ();  ///< k of eq. 8 (sensor frame), non-zero
  double min_angle = 0.0;             ///< [rad]
  double max_angle = 0.17453292519943295;  ///< Δθ [rad] (10 deg)
  double min_length = 0.0;                 ///< [m]
  double max_length = std::numeric_limits<double>::infinity();  ///< [m]
};

/// @brief Indices of the points whose normal passes the angle window and whose projection length
///        (eq. 9) passes the length window (Liu et al. 2022, sec. 2.2, ground step (3)).
/// @param points  points in the sensor frame (origin = sensor) [m]
/// @param normals one normal per point (NaN normals are never candidates)
/// @return ascending indices into `points`
/// @throws plumb::Error when the sizes differ, the axis is zero or a window is NaN
std::vector<std::size_t> presegment(const std::vector<Vector3f>& points, const std::vector<Vector3f>& normals,
                                    const PresegmentSettings& settings = {});

}  // namespace plumb
