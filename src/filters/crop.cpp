// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/filters/crop.hpp"

#include <cmath>

#include "plumb/core/error.hpp"

namespace plumb {
namespace {

/// Keep the finite points for which keep(p) is true; copies every field.
template <typename Keep>
CropResult filter_finite_points(const PointCloud& cloud, Keep keep) {
  CropResult result;
  const std::vector<Vector3f>& pts = cloud.points;
  result.indices.reserve(pts.size());
  for (std::size_t i = 0; i < pts.size(); ++i) {
    if (!pts[i].allFinite()) {
      ++result.num_dropped_non_finite;
      continue;
    }
    if (keep(pts[i])) result.indices.push_back(i);
  }
  const std::vector<std::size_t>& idx = result.indices;
  PointCloud& out = result.cloud;
  auto copy = [&](const auto& src, auto& dst) {
    if (src.empty()) return;
    dst.resize(idx.size());
    for (std::size_t k = 0; k < idx.size(); ++k) dst[k] = src[idx[k]];
  };
  copy(cloud.points, out.points);
  copy(cloud.normals, out.normals);
  copy(cloud.intensities, out.intensities);
  copy(cloud.rings, out.rings);
  copy(cloud.times, out.times);
  copy(cloud.labels, out.labels);
  result.status = out.empty() ? Status::kInsufficientData : Status::kOk;
  return result;
}

}  // namespace

CropResult crop_box(const PointCloud& cloud, const CropBoxSettings& settings) {
  const Vector3d& lo = settings.min;
  const Vector3d& hi = settings.max;
  PLUMB_CHECK(!lo.hasNaN() && !hi.hasNaN(), "crop_box: box bounds must not be NaN (min = "
                                                << lo.transpose() << ", max = " << hi.transpose()
                                                << ")");
  PLUMB_CHECK((lo.array() <= hi.array()).all(), "crop_box: min must be <= max on every axis (min = "
                                                    << lo.transpose() << ", max = "
                                                    << hi.transpose() << ")");
  cloud.check_consistent("crop_box");
  const bool negative = settings.negative;
  if (!settings.T_box_cloud) {
    return filter_finite_points(cloud, [&](const Vector3f& p) {
      const Vector3d q = p.cast<double>();
      const bool inside = (q.array() >= lo.array()).all() && (q.array() <= hi.array()).all();
      return inside != negative;
    });
  }
  const Eigen::Isometry3d& T = *settings.T_box_cloud;
  PLUMB_CHECK(T.matrix().allFinite(), "crop_box: T_box_cloud must be finite");
  const Matrix3d R = T.linear();
  const Vector3d t = T.translation();
  return filter_finite_points(cloud, [&](const Vector3f& p) {
    const Vector3d q = R * p.cast<double>() + t;
    const bool inside = (q.array() >= lo.array()).all() && (q.array() <= hi.array()).all();
    return inside != negative;
  });
}

CropResult range_filter(const PointCloud& cloud, const RangeFilterSettings& settings) {
  const double r_min = settings.min_range;
  const double r_max = settings.max_range;
  PLUMB_CHECK(!std::isnan(r_min) && !std::isnan(r_max) && r_min >= 0.0 && r_max >= r_min,
              "range_filter: need 0 <= min_range <= max_range, got min_range = "
                  << r_min << " m, max_range = " << r_max << " m");
  PLUMB_CHECK(settings.origin.allFinite(),
              "range_filter: origin must be finite, got " << settings.origin.transpose());
  cloud.check_consistent("range_filter");
  const double r_min_sq = r_min * r_min;
  const double r_max_sq = r_max * r_max;
  const Vector3d o = settings.origin;
  return filter_finite_points(cloud, [&](const Vector3f& p) {
    const double d_sq = (p.cast<double>() - o).squaredNorm();
    return d_sq >= r_min_sq && d_sq <= r_max_sq;
  });
}

}  // namespace plumb
