// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/segmentation/ground.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "plumb/core/error.hpp"
#include "plumb/segmentation/presegment.hpp"

#include "segmentation/ground_detail.hpp"

namespace plumb {

namespace detail {

void check_ground_settings(const GroundSettings& s) {
  PLUMB_CHECK(std::isnan(s.sensor_height) || (std::isfinite(s.sensor_height) && s.sensor_height > 0.0),
              "extract_ground: sensor_height = " << s.sensor_height << " must be > 0 (or NaN = unknown)");
  PLUMB_CHECK(std::isfinite(s.height_tolerance) && s.height_tolerance > 0.0,
              "extract_ground: height_tolerance = " << s.height_tolerance << " must be finite and > 0");
  PLUMB_CHECK(std::isfinite(s.max_normal_angle) && s.max_normal_angle >= 0.0 && s.max_normal_angle < 1.5707963267948966,
              "extract_ground: max_normal_angle = " << s.max_normal_angle << " must be in [0, pi/2)");
  PLUMB_CHECK(std::isfinite(s.distance_threshold) && s.distance_threshold > 0.0,
              "extract_ground: distance_threshold = " << s.distance_threshold << " must be finite and > 0");
  PLUMB_CHECK(s.min_plane_fraction >= 0.0 && s.min_plane_fraction <= 1.0,
              "extract_ground: min_plane_fraction = " << s.min_plane_fraction << " must be in [0, 1]");
  PLUMB_CHECK(s.min_sample_inliers >= 3,
              "extract_ground: min_sample_inliers = " << s.min_sample_inliers << " must be >= 3");
}

/// l0 of the lowest large horizontal plane among candidate projection lengths (Liu et al. 2022, sec. 2.2,
/// with the mounting height unknown); NaN when there is no candidate.
double lowest_large_plane_length(const std::vector<double>& lengths, double tolerance, double min_fraction,
                                 std::size_t min_count) {
  if (lengths.empty()) return std::numeric_limits<double>::quiet_NaN();
  const auto [lo_it, hi_it] = std::minmax_element(lengths.begin(), lengths.end());
  const double lo = *lo_it, hi = *hi_it;
  double bin = tolerance / 2.0;
  std::size_t num_bins = static_cast<std::size_t>(std::floor((hi - lo) / bin)) + 1;
  if (num_bins > 100000) {  // absurd spread (airborne data far from the origin): coarser bins
    bin = (hi - lo) / 99999.0;
    num_bins = 100000;
  }
  std::vector<std::size_t> hist(num_bins, 0);
  for (double l : lengths) {
    std::size_t b = static_cast<std::size_t>((l - lo) / bin);
    hist[std::min(b, num_bins - 1)] += 1;
  }
  // Window sums over ±Δl (prefix sums).
  const std::size_t half = std::max<std::size_t>(1, static_cast<std::size_t>(std::round(tolerance / bin)));
  std::vector<std::size_t> prefix(num_bins + 1, 0);
  for (std::size_t b = 0; b < num_bins; ++b) prefix[b + 1] = prefix[b] + hist[b];
  std::vector<std::size_t> window(num_bins);
  std::size_t best = 0;
  for (std::size_t b = 0; b < num_bins; ++b) {
    const std::size_t a = b >= half ? b - half : 0;
    const std::size_t e = std::min(num_bins, b + half + 1);
    window[b] = prefix[e] - prefix[a];
    best = std::max(best, window[b]);
  }
  const double need = std::max(static_cast<double>(min_count), min_fraction * static_cast<double>(best));
  // Largest l whose window qualifies, then the window peak within 2Δl below it.
  std::size_t k = num_bins;
  for (std::size_t b = num_bins; b-- > 0;) {
    if (static_cast<double>(window[b]) >= need) {
      k = b;
      break;
    }
  }
  if (k == num_bins) return std::numeric_limits<double>::quiet_NaN();
  std::size_t peak = k;
  const std::size_t stop = k >= 2 * half ? k - 2 * half : 0;
  for (std::size_t b = k; b-- > stop;) {
    if (window[b] > window[peak]) peak = b;
  }
  // Centre of mass of the peak's bins (finer than the bin grid).
  double sum = 0.0, count = 0.0;
  const std::size_t a = peak >= half ? peak - half : 0;
  const std::size_t e = std::min(num_bins, peak + half + 1);
  for (std::size_t b = a; b < e; ++b) {
    sum += static_cast<double>(hist[b]) * (lo + (static_cast<double>(b) + 0.5) * bin);
    count += static_cast<double>(hist[b]);
  }
  return count > 0.0 ? sum / count : lo + (static_cast<double>(peak) + 0.5) * bin;
}

}  // namespace detail

GroundResult extract_ground(const PointCloud& cloud, const FrameSample& sample,
                            const GroundSettings& settings) {
  const auto t0 = std::chrono::steady_clock::now();
  const GroundSettings& s = settings;
  detail::check_ground_settings(s);
  PLUMB_CHECK(sample.points.size() == sample.normals.size() && sample.points.size() == sample.source.size(),
              "extract_ground: inconsistent sample (" << sample.points.size() << " points, "
                                                      << sample.normals.size() << " normals, "
                                                      << sample.source.size() << " sources)");
  for (std::size_t i : sample.source) {
    PLUMB_CHECK(i < cloud.points.size(), "extract_ground: sample refers to point " << i << " of a cloud of "
                                                                                 << cloud.points.size());
  }
  GroundResult out;
  auto stamp = [&]() {
    out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  };
  if (sample.status != Status::kOk || sample.points.size() < 3) {
    stamp();
    return out;
  }

  // Liu et al. 2022, sec. 2.2, ground step (3): normal within Δθ0 of +z (eq. 8), below the sensor,
  // l (eq. 9) near l0.
  PresegmentSettings ps;
  ps.angle_kind = PresegmentAngle::kNormalToAxis;
  ps.axis = Vector3d::UnitZ();
  ps.max_angle = s.max_normal_angle;
  std::vector<std::size_t> up = presegment(sample.points, sample.normals, ps);
  std::vector<std::size_t> below;
  std::vector<double> lengths;
  below.reserve(up.size());
  lengths.reserve(up.size());
  for (std::size_t i : up) {
    if (!(sample.points[i].z() < 0.0f)) continue;
    below.push_back(i);
    lengths.push_back(projection_length(sample.points[i], sample.normals[i]));
  }
  double l0 = s.sensor_height;
  if (std::isnan(l0)) {
    l0 = detail::lowest_large_plane_length(lengths, s.height_tolerance, s.min_plane_fraction, s.min_sample_inliers);
  }
  out.expected_height = l0;
  if (std::isnan(l0)) {
    stamp();
    return out;
  }
  std::vector<std::size_t> candidates;
  candidates.reserve(below.size());
  for (std::size_t j = 0; j < below.size(); ++j) {
    if (std::abs(lengths[j] - l0) <= s.height_tolerance) candidates.push_back(below[j]);
  }
  out.num_candidates = candidates.size();
  if (candidates.size() < s.min_sample_inliers) {
    stamp();
    return out;
  }

  // Liu et al. 2022, sec. 2.2, ground step (4): RANSAC plane perpendicular to z within Δθ0 (eq. 10-11).
  PlaneRansacSettings rs;
  rs.distance_threshold = s.distance_threshold;
  rs.max_iterations = s.max_iterations;
  rs.confidence = s.confidence;
  rs.constraint = AxisConstraint::kPerpendicular;
  rs.axis = Vector3d::UnitZ();
  rs.max_axis_angle = s.max_normal_angle;
  rs.max_normal_angle = 3.14159265358979323846;  // candidates already passed the normal test
  rs.min_inliers = s.min_sample_inliers;
  rs.seed = s.seed;
  const std::vector<Vector3f> no_normals;
  PlaneRansacResult r = fit_plane_ransac(sample.points, candidates, no_normals, rs);
  out.iterations = r.iterations;
  out.rmse = r.rmse;
  if (r.status != Status::kOk) {
    out.status = r.status;
    {
    stamp();
    return out;
  }
  }
  Plane plane = r.plane;
  if (plane.normal.z() < 0.0) {  // keep the ground's normal up, toward a sensor above it
    plane.normal = -plane.normal;
    plane.offset = -plane.offset;
  }
  out.plane = plane;
  out.sample_inliers = std::move(r.inliers);

  // Full resolution: every finite input point within τ of the plane.
  const float a = static_cast<float>(plane.normal.x()), b = static_cast<float>(plane.normal.y()),
              c = static_cast<float>(plane.normal.z()), d = static_cast<float>(plane.offset);
  const float tau = static_cast<float>(s.distance_threshold);
  for (std::size_t i = 0; i < cloud.points.size(); ++i) {
    const Vector3f& p = cloud.points[i];
    if (std::abs(a * p.x() + b * p.y() + c * p.z() - d) < tau) out.inliers.push_back(i);  // NaN fails
  }
  out.status = Status::kOk;
  {
    stamp();
    return out;
  }
}

GroundResult extract_ground(const PointCloud& cloud, const GroundSettings& settings) {
  const auto t0 = std::chrono::steady_clock::now();
  detail::check_ground_settings(settings);
  FrameSampleSettings ss = settings.sample;
  ss.normal_max_z = std::min(ss.normal_max_z, 0.0f);  // candidates lie below the sensor
  const FrameSample sample = sample_frame(cloud, ss);
  GroundResult out = extract_ground(cloud, sample, settings);
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

}  // namespace plumb
