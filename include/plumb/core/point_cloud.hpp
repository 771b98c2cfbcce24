// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "plumb/core/error.hpp"
#include "plumb/core/types.hpp"

namespace plumb {

/// @brief A point cloud as contiguous arrays (structure of arrays).
///
/// `points` is always present. Every optional field is either empty (absent) or has exactly
/// `points.size()` entries; `check_consistent()` enforces this. Coordinates are float in the
/// cloud's frame [m]; accumulate and solve in double.
struct PointCloud {
  std::vector<Vector3f> points;        ///< x y z [m]
  std::vector<Vector3f> normals;       ///< unit normals, optional
  std::vector<float> intensities;      ///< sensor intensity / reflectivity, optional
  std::vector<std::uint16_t> rings;    ///< laser ring (row) index, optional
  std::vector<float> times;            ///< per-point time relative to the frame stamp [s], optional
  std::vector<std::int32_t> labels;    ///< per-point label (element id, segment class...), optional

  std::size_t size() const { return points.size(); }
  bool empty() const { return points.empty(); }
  bool has_normals() const { return !normals.empty(); }
  bool has_intensities() const { return !intensities.empty(); }
  bool has_rings() const { return !rings.empty(); }
  bool has_times() const { return !times.empty(); }
  bool has_labels() const { return !labels.empty(); }

  /// @brief Remove every point and every field.
  void clear() {
    points.clear();
    normals.clear();
    intensities.clear();
    rings.clear();
    times.clear();
    labels.clear();
  }

  /// @brief Reserve room for n points in `points` and in every present field.
  void reserve(std::size_t n) {
    points.reserve(n);
    if (has_normals()) normals.reserve(n);
    if (has_intensities()) intensities.reserve(n);
    if (has_rings()) rings.reserve(n);
    if (has_times()) times.reserve(n);
    if (has_labels()) labels.reserve(n);
  }

  /// @brief Throw plumb::Error when an optional field is present with the wrong length.
  /// @param where names the caller in the message.
  void check_consistent(const char* where = "PointCloud") const {
    const std::size_t n = points.size();
    auto check = [&](std::size_t m, const char* field) {
      PLUMB_CHECK(m == 0 || m == n, where << ": field '" << field << "' has " << m
                                          << " entries for " << n << " points");
    };
    check(normals.size(), "normals");
    check(intensities.size(), "intensities");
    check(rings.size(), "rings");
    check(times.size(), "times");
    check(labels.size(), "labels");
  }

  /// @brief Copy of the points (and every present field) at `indices`, in that order.
  /// @throws plumb::Error if an index is out of range.
  PointCloud select(const std::vector<std::size_t>& indices) const {
    check_consistent("PointCloud::select");
    PointCloud out;
    out.points.reserve(indices.size());
    for (std::size_t i : indices) {
      PLUMB_CHECK(i < points.size(), "PointCloud::select: index " << i << " out of range for "
                                                                  << points.size() << " points");
      out.points.push_back(points[i]);
    }
    auto copy = [&](const auto& src, auto& dst) {
      if (src.empty()) return;
      dst.reserve(indices.size());
      for (std::size_t i : indices) dst.push_back(src[i]);
    };
    copy(normals, out.normals);
    copy(intensities, out.intensities);
    copy(rings, out.rings);
    copy(times, out.times);
    copy(labels, out.labels);
    return out;
  }

  /// @brief Indices of the points whose three coordinates are finite.
  std::vector<std::size_t> finite_indices() const {
    std::vector<std::size_t> idx;
    idx.reserve(points.size());
    for (std::size_t i = 0; i < points.size(); ++i) {
      if (points[i].allFinite()) idx.push_back(i);
    }
    return idx;
  }
};

/// @brief Apply a rigid transform to points (and rotate normals), in place.
/// @param T_dst_src maps the cloud's current frame (src) into dst.
inline void transform_in_place(PointCloud& cloud, const Eigen::Isometry3d& T_dst_src) {
  const Eigen::Matrix3f R = T_dst_src.linear().cast<float>();
  const Eigen::Vector3f t = T_dst_src.translation().cast<float>();
  for (auto& p : cloud.points) p = R * p + t;
  for (auto& n : cloud.normals) n = R * n;
}

/// @brief Transformed copy of a cloud; see transform_in_place().
inline PointCloud transformed(PointCloud cloud, const Eigen::Isometry3d& T_dst_src) {
  transform_in_place(cloud, T_dst_src);
  return cloud;
}

}  // namespace plumb
