// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cstddef>
#include <vector>

#include <Eigen/Geometry>

#include "plumb/core/error.hpp"

namespace plumb {

/// @brief A stamped sequence of 6-DoF poses `T_world_body` (body into world).
///
/// `stamps` is either empty (e.g. a KITTI pose file without a times file) or has one entry per
/// pose [s]. Poses are double precision; see docs/design.md for the world frame.
struct Trajectory {
  std::vector<double> stamps;              ///< [s], empty or poses.size() entries
  std::vector<Eigen::Isometry3d> poses;    ///< T_world_body

  std::size_t size() const { return poses.size(); }
  bool empty() const { return poses.empty(); }
  bool has_stamps() const { return !stamps.empty(); }

  void push_back(double stamp, const Eigen::Isometry3d& T_world_body) {
    stamps.push_back(stamp);
    poses.push_back(T_world_body);
  }

  /// @brief Throw plumb::Error when stamps and poses disagree in length.
  void check_consistent(const char* where = "Trajectory") const {
    PLUMB_CHECK(stamps.empty() || stamps.size() == poses.size(),
                where << ": " << stamps.size() << " stamps for " << poses.size() << " poses");
  }
};

}  // namespace plumb
