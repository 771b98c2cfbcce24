// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Undoing a LiDAR frame's motion distortion: the wheel-odometry pose at any time
///        (OdometryInterpolator) and the frame moved into the LiDAR frame at its stamp (deskew_frame).
///        What a robot's own loop needs between its driver and BimOdometry, without any file.

#include <functional>
#include <vector>

#include <Eigen/Geometry>

#include "plumb/core/point_cloud.hpp"
#include "plumb/core/pose2.hpp"
#include "plumb/core/sensor_data.hpp"

namespace plumb {

/// @brief Wheel-odometry pose at any time, linearly interpolated in SE(2) between recorded samples
///        (clamped to the first / last one): the prior and the deskewing motion of each frame.
class OdometryInterpolator {
 public:
  /// @throws plumb::Error when there is no sample or the stamps do not increase
  explicit OdometryInterpolator(std::vector<OdomSample> samples);
  Pose2 at(double t) const;
  double first_stamp() const { return s_.front().stamp; }
  double last_stamp() const { return s_.back().stamp; }

 private:
  std::vector<OdomSample> s_;
};

/// @brief Undo the motion distortion of a frame: each point, measured at stamp + time_i in the LiDAR
///        frame of that instant, is moved into the LiDAR frame at `stamp` using T_ref_base(t), the base
///        pose at absolute time t in any fixed frame. Points without a time are left as they are.
/// @throws plumb::Error when the frame has times but not one per point
void deskew_frame(PointCloud& frame, double stamp, const Eigen::Isometry3d& T_base_lidar,
                  const std::function<Eigen::Isometry3d(double)>& T_ref_base);

}  // namespace plumb
