// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/calibration/tuple_extraction.hpp"

#include <algorithm>
#include <cmath>

#include "plumb/core/error.hpp"

namespace plumb {

std::optional<Vector2d> interpolate_wheel_angles(const std::vector<WheelEncoderReading>& readings, double t,
                                                 double max_gap) {
  if (readings.empty() || !std::isfinite(t)) return std::nullopt;
  if (t < readings.front().stamp || t > readings.back().stamp) return std::nullopt;
  // First reading with stamp >= t.
  const auto it = std::lower_bound(readings.begin(), readings.end(), t,
                                   [](const WheelEncoderReading& r, double s) { return r.stamp < s; });
  if (it->stamp == t) return Vector2d(it->left, it->right);
  const WheelEncoderReading& b = *it;
  const WheelEncoderReading& a = *(it - 1);
  const double gap = b.stamp - a.stamp;
  if (!(gap <= max_gap) || !(gap > 0.0)) return std::nullopt;
  const double alpha = (t - a.stamp) / gap;
  return Vector2d(a.left + alpha * (b.left - a.left), a.right + alpha * (b.right - a.right));
}

ScanMatcher plicp_scan_matcher(const PlicpSettings& settings, bool accept_degenerate) {
  return [settings, accept_degenerate](const LaserScan& reference, const LaserScan& current,
                                       const Pose2& guess) -> std::optional<Pose2> {
    const PlicpReference ref(reference);
    const PlicpResult r = plicp(current, ref, guess, settings);
    if (r.status != Status::kOk || (r.degenerate && !accept_degenerate)) return std::nullopt;
    return r.T_ref_cur;
  };
}

TupleExtractionResult extract_calibration_tuples(const std::vector<LaserScan>& scans,
                                                 const std::vector<WheelEncoderReading>& wheels,
                                                 const ScanMatcher& matcher,
                                                 const TupleExtractionSettings& settings) {
  PLUMB_CHECK(settings.scan_spacing >= 1, "extract_calibration_tuples: scan_spacing must be >= 1");
  PLUMB_CHECK(settings.max_encoder_gap > 0.0,
              "extract_calibration_tuples: max_encoder_gap must be > 0, got " << settings.max_encoder_gap);
  PLUMB_CHECK(std::isfinite(settings.max_speed_change) && settings.max_speed_change >= 0.0 &&
                  std::isfinite(settings.max_speed_change_ratio) && settings.max_speed_change_ratio >= 0.0,
              "extract_calibration_tuples: max_speed_change and max_speed_change_ratio must be finite and >= 0");
  PLUMB_CHECK(static_cast<bool>(matcher), "extract_calibration_tuples: no scan matcher given");
  for (std::size_t i = 0; i < wheels.size(); ++i) {
    PLUMB_CHECK(std::isfinite(wheels[i].stamp) && std::isfinite(wheels[i].left) && std::isfinite(wheels[i].right),
                "extract_calibration_tuples: wheel reading " << i << " is not finite");
    PLUMB_CHECK(i == 0 || wheels[i].stamp > wheels[i - 1].stamp,
                "extract_calibration_tuples: wheel reading " << i << " stamp " << wheels[i].stamp
                                                             << " does not increase");
  }
  for (std::size_t i = 1; i < scans.size(); ++i) {
    PLUMB_CHECK(scans[i].stamp > scans[i - 1].stamp,
                "extract_calibration_tuples: scan " << i << " stamp " << scans[i].stamp << " does not increase");
  }

  const OdometryLaserParams& nominal = settings.nominal;
  const bool have_nominal = nominal.axle > 0.0;
  TupleExtractionResult result;
  // Without nominal parameters, a spaced pair's guess is the chain of consecutive matches: a large
  // motion from an identity guess can converge to a wrong local minimum, a scan-to-next-scan one
  // rarely does.
  std::vector<std::optional<Pose2>> steps;
  if (!have_nominal && settings.scan_spacing > 1 && scans.size() > settings.scan_spacing) {
    steps.resize(scans.size() - 1);
    for (std::size_t i = 0; i + 1 < scans.size(); ++i) steps[i] = matcher(scans[i], scans[i + 1], Pose2{});
  }
  auto chained_guess = [&steps](std::size_t k, std::size_t j) {
    Pose2 g;
    for (std::size_t i = k; i < j; ++i) {
      if (!steps[i] || !steps[i]->vector().allFinite()) return Pose2{};
      g = g.oplus(*steps[i]);
    }
    return g;
  };
  for (std::size_t k = 0; k + settings.scan_spacing < scans.size(); ++k) {
    const std::size_t j = k + settings.scan_spacing;
    ++result.num_pairs;
    const auto a = interpolate_wheel_angles(wheels, scans[k].stamp, settings.max_encoder_gap);
    const auto b = interpolate_wheel_angles(wheels, scans[j].stamp, settings.max_encoder_gap);
    if (!a || !b) {
      ++result.num_without_odometry;
      continue;
    }
    CalibrationTuple t;
    t.T = scans[j].stamp - scans[k].stamp;
    t.phi_left = ((*b)(0) - (*a)(0)) / t.T;
    t.phi_right = ((*b)(1) - (*a)(1)) / t.T;
    if (settings.check_constant_speed) {
      // The tuple model assumes constant wheel speeds over the interval: compare its two halves.
      const double mid_t = 0.5 * (scans[k].stamp + scans[j].stamp);
      const auto mid = interpolate_wheel_angles(wheels, mid_t, settings.max_encoder_gap);
      if (!mid) {
        ++result.num_without_odometry;
        continue;
      }
      const double half = 0.5 * t.T;
      const Vector2d first = (*mid - *a) / half, second = (*b - *mid) / half;
      const double change = (second - first).cwiseAbs().maxCoeff();
      const double speed = std::max(std::abs(t.phi_left), std::abs(t.phi_right));
      if (change > settings.max_speed_change + settings.max_speed_change_ratio * speed) {
        ++result.num_speed_changes;
        continue;
      }
    }
    const Pose2 guess = have_nominal     ? predicted_laser_motion(nominal, t)
                        : steps.empty() ? Pose2{}
                                        : chained_guess(k, j);
    const std::optional<Pose2> s = matcher(scans[k], scans[j], guess);
    if (!s || !s->vector().allFinite()) {
      ++result.num_match_failures;
      continue;
    }
    t.laser_motion = *s;
    result.tuples.push_back(t);
    result.scan_pairs.emplace_back(k, j);
  }
  result.status = result.tuples.empty() ? Status::kInsufficientData : Status::kOk;
  return result;
}

}  // namespace plumb
