// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/segmentation/segment_frame.hpp"

#include <chrono>

#include "segmentation/ground_detail.hpp"

namespace plumb {

SegmentResult segment_frame(const PointCloud& cloud, const SegmentSettings& settings) {
  const auto t0 = std::chrono::steady_clock::now();
  detail::check_ground_settings(settings.ground);
  SegmentResult out;
  const FrameSample sample = sample_frame(cloud, settings.sample);
  out.num_sample = sample.points.size();
  out.timings.sample = sample.seconds;
  out.ground = extract_ground(cloud, sample, settings.ground);
  out.timings.ground = out.ground.seconds;
  out.vertical = extract_vertical_planes(cloud, sample, &out.ground, settings.vertical);
  out.timings.vertical = out.vertical.seconds;

  // Vertical labels first (one vectorizable pass), then ground (ground inliers are never vertical).
  const std::size_t n = cloud.points.size();
  out.labels.resize(n);
  const std::int32_t* plane_of = out.vertical.plane_of_point.data();
  std::int32_t* labels = out.labels.data();
  for (std::size_t i = 0; i < n; ++i) labels[i] = plane_of[i] >= 0 ? kSegmentVertical : kSegmentOther;
  out.num_vertical = out.vertical.num_points;
  if (out.ground.status == Status::kOk) {
    for (std::size_t i : out.ground.inliers) labels[i] = kSegmentGround;
    out.num_ground = out.ground.inliers.size();
  }
  out.num_other = n - out.num_ground - out.num_vertical;
  out.status = out.ground.status;
  out.timings.total = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

}  // namespace plumb
