// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// @brief The pose exclusion of align_sac_ia(), which localize_coarse_to_fine() shares, for plumb's
///        own sources (not installed).

#include <vector>

#include <Eigen/Geometry>

namespace plumb::detail {

/// True when T is within `distance` (translation) and `angle` (rotation) of one of `poses`.
bool near_any(const Eigen::Isometry3d& T, const std::vector<Eigen::Isometry3d>& poses, double distance,
              double angle);

}  // namespace plumb::detail
