// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/eval/kitti_segments.hpp"

#include <algorithm>
#include <cmath>

#include "plumb/core/error.hpp"
#include "plumb/eval/metrics.hpp"

namespace plumb::eval {

KittiSegmentResult compute_kitti_segment_errors(const Trajectory& estimate, const Trajectory& reference,
                                                const KittiSegmentSettings& settings) {
  PLUMB_CHECK(!estimate.empty() && !reference.empty(), "compute_kitti_segment_errors: empty trajectory");
  PLUMB_CHECK(estimate.size() == reference.size(),
              "compute_kitti_segment_errors: estimate has " << estimate.size() << " poses, reference "
                                                            << reference.size());
  PLUMB_CHECK(settings.step_frames > 0, "compute_kitti_segment_errors: step_frames must be > 0");
  for (double length : settings.lengths) {
    PLUMB_CHECK(std::isfinite(length) && length > 0.0,
                "compute_kitti_segment_errors: segment length must be > 0, got " << length);
  }
  const std::vector<double> distance = path_lengths(reference);
  const std::size_t n = reference.size();
  KittiSegmentResult result;
  std::vector<KittiLengthAverage> sums(settings.lengths.size());
  for (std::size_t first = 0; first < n; first += settings.step_frames) {
    for (std::size_t k = 0; k < settings.lengths.size(); ++k) {
      const double length = settings.lengths[k];
      // First frame strictly farther than `length` along the path; distance is non-decreasing.
      const auto it = std::upper_bound(distance.begin() + static_cast<std::ptrdiff_t>(first), distance.end(),
                                       distance[first] + length);
      if (it == distance.end()) continue;
      const auto last = static_cast<std::size_t>(it - distance.begin());
      const Eigen::Isometry3d delta_ref = reference.poses[first].inverse() * reference.poses[last];
      const Eigen::Isometry3d delta_est = estimate.poses[first].inverse() * estimate.poses[last];
      const Eigen::Isometry3d E = delta_est.inverse() * delta_ref;
      const double c = std::clamp(0.5 * (E.linear().trace() - 1.0), -1.0, 1.0);
      KittiSegmentError segment;
      segment.first_frame = first;
      segment.last_frame = last;
      segment.length = length;
      segment.translation_error = E.translation().norm() / length;
      segment.rotation_error = std::acos(c) / length;
      result.segments.push_back(segment);
      sums[k].num_segments += 1;
      sums[k].translation_pct += segment.translation_error;
      sums[k].rotation_deg_per_m += segment.rotation_error;
    }
  }
  constexpr double kRadToDeg = 180.0 / 3.14159265358979323846;
  if (result.segments.empty()) {
    result.status = Status::kInsufficientData;
    return result;
  }
  for (const KittiSegmentError& s : result.segments) {
    result.translation_pct += s.translation_error;
    result.rotation_deg_per_m += s.rotation_error;
  }
  const double count = static_cast<double>(result.segments.size());
  result.translation_pct *= 100.0 / count;
  result.rotation_deg_per_m *= kRadToDeg / count;
  for (std::size_t k = 0; k < sums.size(); ++k) {
    if (sums[k].num_segments == 0) continue;
    KittiLengthAverage average = sums[k];
    const double m = static_cast<double>(average.num_segments);
    average.length = settings.lengths[k];
    average.translation_pct *= 100.0 / m;
    average.rotation_deg_per_m *= kRadToDeg / m;
    result.per_length.push_back(average);
  }
  return result;
}

}  // namespace plumb::eval
