// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/loam/range_image.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

#include "plumb/core/error.hpp"

namespace plumb {

namespace loam_detail {

constexpr double kDegToRad = kPi / 180.0;

// Range of a point in [min_range, max_range] with finite coordinates, else a negative value.
double valid_range(const Vector3f& p, const RangeImageSettings& s) {
  if (!p.allFinite()) return -1.0;
  const double r = p.cast<double>().norm();
  if (!(r >= s.min_range && r <= s.max_range)) return -1.0;
  return r;
}

// Zhou et al. 2021, eq. 1-4: alpha = asin(z / l).
double elevation(const Vector3f& p, double r) {
  return std::asin(std::clamp(static_cast<double>(p.z()) / r, -1.0, 1.0));
}

void check_range_image_settings(const RangeImageSettings& s) {
  PLUMB_CHECK(std::isfinite(s.horizontal_resolution_deg) && s.horizontal_resolution_deg >= 0.006 &&
                  s.horizontal_resolution_deg <= 360.0,
              "build_range_image: horizontal_resolution_deg must be in [0.006, 360], got "
                  << s.horizontal_resolution_deg);
  PLUMB_CHECK(std::isfinite(s.min_range) && s.min_range >= 0.0 && !(s.max_range < s.min_range),
              "build_range_image: need 0 <= min_range <= max_range, got [" << s.min_range << ", "
                                                                            << s.max_range << "]");
  PLUMB_CHECK(s.num_rings >= 0 && s.num_rings < RangeImage::kNoRing,
              "build_range_image: num_rings must be in [0, 65534], got " << s.num_rings);
  PLUMB_CHECK(std::isfinite(s.auto_bin_gap_deg) && s.auto_bin_gap_deg > 0.0,
              "build_range_image: auto_bin_gap_deg must be > 0, got " << s.auto_bin_gap_deg);
  PLUMB_CHECK(std::isfinite(s.max_vertical_angle_error_deg) && s.max_vertical_angle_error_deg > 0.0,
              "build_range_image: max_vertical_angle_error_deg must be > 0, got "
                  << s.max_vertical_angle_error_deg);
  for (double a : s.vertical_angles_deg) {
    PLUMB_CHECK(std::isfinite(a) && a >= -90.0 && a <= 90.0,
                "build_range_image: vertical angle " << a << " deg is not in [-90, 90]");
  }
}

}  // namespace loam_detail

std::vector<std::uint16_t> auto_bin_rings(const PointCloud& cloud,
                                          const RangeImageSettings& settings, int& num_rows) {
  std::vector<std::uint16_t> rows(cloud.size(), RangeImage::kNoRing);
  std::vector<std::pair<double, std::size_t>> el;  // (elevation, point)
  el.reserve(cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const double r = loam_detail::valid_range(cloud.points[i], settings);
    if (r > 0.0) el.emplace_back(loam_detail::elevation(cloud.points[i], r), i);
  }
  std::sort(el.begin(), el.end());
  const double gap = settings.auto_bin_gap_deg * loam_detail::kDegToRad;
  num_rows = 0;
  std::size_t begin = 0;
  while (begin < el.size()) {
    std::size_t end = begin + 1;
    while (end < el.size() && el[end].first - el[end - 1].first <= gap) ++end;
    if (end - begin >= std::max<std::size_t>(settings.auto_bin_min_points, 1)) {
      PLUMB_CHECK(num_rows < RangeImage::kNoRing - 1,
                  "auto_bin_rings: more than 65534 elevation clusters (auto_bin_gap_deg too small?)");
      for (std::size_t k = begin; k < end; ++k) {
        rows[el[k].second] = static_cast<std::uint16_t>(num_rows);
      }
      ++num_rows;
    }
    begin = end;
  }
  return rows;
}

RangeImage build_range_image(const PointCloud& cloud, const RangeImageSettings& settings) {
  using namespace loam_detail;
  cloud.check_consistent("build_range_image");
  check_range_image_settings(settings);

  RingSource source = settings.ring_source;
  if (source == RingSource::kAuto) {
    source = cloud.has_rings() ? RingSource::kField
             : !settings.vertical_angles_deg.empty() ? RingSource::kVerticalAngles
                                                     : RingSource::kAutoBin;
  }
  PLUMB_CHECK(source != RingSource::kField || cloud.has_rings() || cloud.empty(),
              "build_range_image: ring_source is kField but the cloud has no ring field");
  PLUMB_CHECK(source != RingSource::kVerticalAngles || !settings.vertical_angles_deg.empty(),
              "build_range_image: ring_source is kVerticalAngles but vertical_angles_deg is empty");

  RangeImage img;
  img.point_row.assign(cloud.size(), RangeImage::kNoRing);
  img.point_column.assign(cloud.size(), 0);

  // Rows.
  int num_rows = 0;
  if (source == RingSource::kField) {
    if (settings.num_rings > 0) {
      num_rows = settings.num_rings;
    } else {
      for (std::uint16_t r : cloud.rings) num_rows = std::max(num_rows, static_cast<int>(r) + 1);
    }
    for (std::size_t i = 0; i < cloud.size(); ++i) {
      PLUMB_CHECK(static_cast<int>(cloud.rings[i]) < num_rows,
                  "build_range_image: point " << i << " has ring " << cloud.rings[i]
                                              << " but num_rings is " << num_rows);
      PLUMB_CHECK(cloud.rings[i] != RangeImage::kNoRing,
                  "build_range_image: point " << i << " has ring 65535 (reserved)");
      if (valid_range(cloud.points[i], settings) > 0.0) img.point_row[i] = cloud.rings[i];
    }
  } else if (source == RingSource::kVerticalAngles) {
    std::vector<double> angles = settings.vertical_angles_deg;
    std::sort(angles.begin(), angles.end());
    PLUMB_CHECK(angles.size() < RangeImage::kNoRing, "build_range_image: too many vertical angles");
    num_rows = static_cast<int>(angles.size());
    for (double& a : angles) a *= kDegToRad;
    const double max_err = settings.max_vertical_angle_error_deg * kDegToRad;
    for (std::size_t i = 0; i < cloud.size(); ++i) {
      const double r = valid_range(cloud.points[i], settings);
      if (r <= 0.0) continue;
      const double a = elevation(cloud.points[i], r);
      const auto it = std::lower_bound(angles.begin(), angles.end(), a);
      std::size_t best = static_cast<std::size_t>(it - angles.begin());
      if (best == angles.size() || (best > 0 && a - angles[best - 1] < angles[best] - a)) --best;
      if (std::abs(angles[best] - a) <= max_err) img.point_row[i] = static_cast<std::uint16_t>(best);
    }
  } else {
    img.point_row = auto_bin_rings(cloud, settings, num_rows);
  }

  // Columns: beta = atan2(x, y) in [0, 2 pi) (Zhou et al. 2021, eq. 1-4).
  const double res = settings.horizontal_resolution_deg * kDegToRad;
  const int num_columns = std::max(1, static_cast<int>(std::ceil(360.0 / settings.horizontal_resolution_deg - 1e-9)));
  img.num_rows = num_rows;
  img.num_columns = num_columns;
  const std::size_t num_pixels = static_cast<std::size_t>(num_rows) * static_cast<std::size_t>(num_columns);
  img.index.assign(num_pixels, RangeImage::kEmpty);
  img.range.assign(num_pixels, std::numeric_limits<float>::infinity());
  img.row_elevation.assign(static_cast<std::size_t>(num_rows), 0.0);
  std::vector<std::size_t> row_count(static_cast<std::size_t>(num_rows), 0);

  PLUMB_CHECK(cloud.size() < static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max()),
              "build_range_image: too many points (" << cloud.size() << ")");
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    if (img.point_row[i] == RangeImage::kNoRing) {
      ++img.num_dropped;
      continue;
    }
    const Vector3f& p = cloud.points[i];
    const double r = valid_range(p, settings);
    if (r <= 0.0) {  // ring field given for an invalid point
      img.point_row[i] = RangeImage::kNoRing;
      ++img.num_dropped;
      continue;
    }
    double beta = std::atan2(static_cast<double>(p.x()), static_cast<double>(p.y()));
    if (beta < 0.0) beta += 2.0 * kPi;
    int col = static_cast<int>(beta / res);
    if (col >= num_columns) col -= num_columns;  // beta rounding up to 2 pi
    col = std::clamp(col, 0, num_columns - 1);
    const int row = img.point_row[i];
    img.point_column[i] = static_cast<std::uint16_t>(col);
    img.row_elevation[static_cast<std::size_t>(row)] += elevation(p, r);
    ++row_count[static_cast<std::size_t>(row)];
    const std::size_t pix = static_cast<std::size_t>(row) * static_cast<std::size_t>(num_columns) +
                            static_cast<std::size_t>(col);
    if (img.index[pix] == RangeImage::kEmpty) {
      img.index[pix] = static_cast<std::int32_t>(i);
      img.range[pix] = static_cast<float>(r);
      ++img.num_pixels_filled;
    } else {
      ++img.num_collisions;
      if (static_cast<float>(r) < img.range[pix]) {
        img.index[pix] = static_cast<std::int32_t>(i);
        img.range[pix] = static_cast<float>(r);
      }
    }
  }
  for (std::size_t r = 0; r < row_count.size(); ++r) {
    if (row_count[r] > 0) img.row_elevation[r] /= static_cast<double>(row_count[r]);
  }
  img.status = img.num_pixels_filled > 0 ? Status::kOk : Status::kInsufficientData;
  return img;
}

}  // namespace plumb
