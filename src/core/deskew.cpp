// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/core/deskew.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "plumb/core/error.hpp"

namespace plumb {

OdometryInterpolator::OdometryInterpolator(std::vector<OdomSample> samples) : s_(std::move(samples)) {
  PLUMB_CHECK(!s_.empty(), "OdometryInterpolator: no odometry sample (odom.csv is empty)");
  for (std::size_t i = 1; i < s_.size(); ++i) {
    PLUMB_CHECK(s_[i].stamp > s_[i - 1].stamp, "OdometryInterpolator: stamps must increase (sample " << i << ")");
  }
}

Pose2 OdometryInterpolator::at(double t) const {
  if (t <= s_.front().stamp) return s_.front().pose;
  if (t >= s_.back().stamp) return s_.back().pose;
  const auto it = std::lower_bound(s_.begin(), s_.end(), t, [](const OdomSample& a, double v) { return a.stamp < v; });
  const OdomSample& b = *it;
  const OdomSample& a = *(it - 1);
  return interpolate_pose2(a.pose, b.pose, (t - a.stamp) / (b.stamp - a.stamp));
}

void deskew_frame(PointCloud& frame, double stamp, const Eigen::Isometry3d& T_base_lidar,
                  const std::function<Eigen::Isometry3d(double)>& T_ref_base) {
  if (!frame.has_times()) return;
  PLUMB_CHECK(frame.times.size() == frame.points.size(), "deskew_frame: " << frame.times.size() << " times for "
                                                                          << frame.points.size() << " points");
  const Eigen::Isometry3d T_lidar_base = T_base_lidar.inverse();
  const Eigen::Isometry3d T_base0_ref = T_ref_base(stamp).inverse();
  // Points of one sweep share a few hundred distinct firing times: cache the last transform.
  float last_time = std::numeric_limits<float>::quiet_NaN();
  Eigen::Matrix3f R = Eigen::Matrix3f::Identity();
  Eigen::Vector3f t = Eigen::Vector3f::Zero();
  for (std::size_t i = 0; i < frame.points.size(); ++i) {
    const float ti = frame.times[i];
    if (!std::isfinite(ti)) continue;
    if (ti != last_time) {
      const Eigen::Isometry3d T = T_lidar_base * T_base0_ref * T_ref_base(stamp + ti) * T_base_lidar;
      R = T.linear().cast<float>();
      t = T.translation().cast<float>();
      last_time = ti;
    }
    frame.points[i] = R * frame.points[i] + t;
  }
}

}  // namespace plumb
