// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/eval/metrics.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "plumb/core/error.hpp"
#include "plumb/core/lie.hpp"

namespace plumb::eval {
namespace {

constexpr double kRadToDeg = 180.0 / 3.14159265358979323846;

void check_paired(const Trajectory& estimate, const Trajectory& reference, const char* where) {
  PLUMB_CHECK(!estimate.empty() && !reference.empty(), where << ": empty trajectory");
  PLUMB_CHECK(estimate.size() == reference.size(),
              where << ": estimate has " << estimate.size() << " poses, reference " << reference.size()
                    << " (associate them first)");
}

double rotation_angle(const Matrix3d& R) { return so3::log(R).norm(); }

// |a - b| over `axes`.
double distance(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b, PositionAxes axes) {
  const Vector3d d = a.translation() - b.translation();
  return axes == PositionAxes::kXY ? d.head<2>().norm() : d.norm();
}

ErrorSeries make_series(std::vector<double> values) {
  ErrorSeries series;
  if (!values.empty()) series.stats = compute_stats(values);
  series.values = std::move(values);
  return series;
}

// Nearest entry of `stamps` (+ offset) to `stamp`, first index on ties, as numpy's argmin.
std::size_t nearest(const std::vector<double>& stamps, double offset, double stamp, bool sorted) {
  if (!sorted) {
    std::size_t best = 0;
    double best_diff = std::abs(stamps[0] + offset - stamp);
    for (std::size_t k = 1; k < stamps.size(); ++k) {
      const double diff = std::abs(stamps[k] + offset - stamp);
      if (diff < best_diff) { best = k; best_diff = diff; }
    }
    return best;
  }
  const auto it = std::lower_bound(stamps.begin(), stamps.end(), stamp - offset);
  std::size_t hi = static_cast<std::size_t>(it - stamps.begin());
  if (hi == stamps.size()) hi = stamps.size() - 1;
  std::size_t best = hi;
  if (hi > 0 && std::abs(stamps[hi - 1] + offset - stamp) <= std::abs(stamps[hi] + offset - stamp)) {
    best = hi - 1;
  }
  while (best > 0 && stamps[best - 1] == stamps[best]) --best;
  return best;
}

void check_finite_poses(const Trajectory& trajectory, const char* which) {
  for (std::size_t i = 0; i < trajectory.size(); ++i) {
    PLUMB_CHECK(trajectory.poses[i].matrix().allFinite(),
                "associate: " << which << " pose " << i << " is not finite (NaN or infinity)");
  }
}

void check_increasing_stamps(const Trajectory& trajectory, const char* which) {
  for (std::size_t i = 1; i < trajectory.stamps.size(); ++i) {
    PLUMB_CHECK(trajectory.stamps[i] > trajectory.stamps[i - 1],
                "associate: " << which << " stamps do not strictly increase: pose " << i << " has stamp "
                              << trajectory.stamps[i] << " after " << trajectory.stamps[i - 1] << " at pose "
                              << i - 1);
  }
}

void check_pair_count(std::size_t pairs, const Trajectory& shorter, const char* shorter_name,
                      const Trajectory& longer, const AssociationSettings& settings, bool by_stamp) {
  const double needed_share = settings.min_pair_fraction * static_cast<double>(shorter.size());
  if (pairs >= settings.min_pairs && static_cast<double>(pairs) >= needed_share) return;
  std::ostringstream os;
  os.precision(10);
  os << "associate: only " << pairs << " pose pairs " << (by_stamp ? "matched by stamp" : "paired by index")
     << " out of the " << shorter.size() << " poses of the shorter trajectory (the " << shorter_name
     << "); at least " << settings.min_pairs << " and " << settings.min_pair_fraction * 100.0
     << " % of them are needed";
  if (by_stamp) {
    os << ". Stamps: " << shorter_name << ' ' << shorter.stamps.front() << " .. " << shorter.stamps.back()
       << ", the other " << longer.stamps.front() << " .. " << longer.stamps.back() << " (max difference "
       << settings.max_time_difference << " s, time offset " << settings.time_offset
       << " s): are both in seconds on the same clock?";
  }
  throw Error(os.str());
}

}  // namespace

ErrorStats compute_stats(const std::vector<double>& errors) {
  PLUMB_CHECK(!errors.empty(), "compute_stats: no errors");
  ErrorStats s;
  s.count = errors.size();
  const double n = static_cast<double>(errors.size());
  double sum = 0.0;
  s.min = std::numeric_limits<double>::infinity();
  s.max = -std::numeric_limits<double>::infinity();
  for (double e : errors) {
    PLUMB_CHECK(std::isfinite(e), "compute_stats: error value " << e << " is not finite");
    sum += e;
    s.sse += e * e;
    s.min = std::min(s.min, e);
    s.max = std::max(s.max, e);
  }
  s.mean = sum / n;
  s.rmse = std::sqrt(s.sse / n);
  double var = 0.0;
  for (double e : errors) var += (e - s.mean) * (e - s.mean);
  s.std = std::sqrt(var / n);
  std::vector<double> sorted = errors;
  const std::size_t mid = sorted.size() / 2;
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(mid), sorted.end());
  s.median = sorted[mid];
  if (sorted.size() % 2 == 0) {
    const double lower = *std::max_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(mid));
    s.median = 0.5 * (lower + s.median);
  }
  return s;
}

AssociationResult associate(const Trajectory& estimate, const Trajectory& reference,
                            const AssociationSettings& settings) {
  estimate.check_consistent("associate: estimate");
  reference.check_consistent("associate: reference");
  PLUMB_CHECK(!estimate.empty() && !reference.empty(), "associate: empty trajectory");
  PLUMB_CHECK(std::isfinite(settings.max_time_difference) && settings.max_time_difference >= 0.0 &&
                  std::isfinite(settings.time_offset) && std::isfinite(settings.min_pair_fraction) &&
                  settings.min_pair_fraction >= 0.0 && settings.min_pair_fraction <= 1.0,
              "associate: invalid settings (max_time_difference " << settings.max_time_difference
                  << ", time_offset " << settings.time_offset << ", min_pair_fraction "
                  << settings.min_pair_fraction << ")");
  check_finite_poses(estimate, "estimate");
  check_finite_poses(reference, "reference");
  check_increasing_stamps(estimate, "estimate");
  check_increasing_stamps(reference, "reference");
  AssociationResult result;
  if (!estimate.has_stamps() || !reference.has_stamps()) {
    PLUMB_CHECK(estimate.size() == reference.size(),
                "associate: without stamps on both trajectories they are paired by index, but the estimate has "
                    << estimate.size() << " poses and the reference " << reference.size());
    result.estimate = estimate;
    result.reference = reference;
    if (!result.estimate.has_stamps()) result.estimate.stamps = reference.stamps;
    if (!result.reference.has_stamps()) result.reference.stamps = estimate.stamps;
    result.estimate_indices.resize(estimate.size());
    for (std::size_t i = 0; i < estimate.size(); ++i) result.estimate_indices[i] = i;
    result.reference_indices = result.estimate_indices;
    check_pair_count(estimate.size(), estimate, "estimate", reference, settings, false);
    return result;
  }
  result.by_stamp = true;
  // Walk the shorter trajectory (the estimate on equal sizes), search the longer one.
  const bool estimate_longer = estimate.size() > reference.size();
  const Trajectory& shorter = estimate_longer ? reference : estimate;
  const Trajectory& longer = estimate_longer ? estimate : reference;
  // Offset applied to the longer one so that it always shifts the estimate's stamps.
  const double offset = estimate_longer ? settings.time_offset : -settings.time_offset;
  std::vector<std::size_t>& short_ids = estimate_longer ? result.reference_indices : result.estimate_indices;
  std::vector<std::size_t>& long_ids = estimate_longer ? result.estimate_indices : result.reference_indices;
  for (std::size_t i = 0; i < shorter.size(); ++i) {
    const std::size_t k = nearest(longer.stamps, offset, shorter.stamps[i], true);
    if (std::abs(longer.stamps[k] + offset - shorter.stamps[i]) <= settings.max_time_difference) {
      short_ids.push_back(i);
      long_ids.push_back(k);
    }
  }
  check_pair_count(short_ids.size(), shorter, estimate_longer ? "reference" : "estimate", longer, settings, true);
  for (std::size_t k = 0; k < result.estimate_indices.size(); ++k) {
    const std::size_t ie = result.estimate_indices[k];
    const std::size_t ir = result.reference_indices[k];
    result.estimate.push_back(estimate.stamps[ie], estimate.poses[ie]);
    result.reference.push_back(reference.stamps[ir], reference.poses[ir]);
  }
  return result;
}

ApeResult compute_ape(const Trajectory& estimate, const Trajectory& reference, const ApeSettings& settings) {
  check_paired(estimate, reference, "compute_ape");
  const AlignResult aligned = align_trajectory(estimate, reference, settings.align);
  const std::size_t n = reference.size();
  std::vector<double> translation(n), rotation(n), full(n);
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Isometry3d& P = aligned.aligned.poses[i];
    const Eigen::Isometry3d& Q = reference.poses[i];
    translation[i] = distance(P, Q, settings.axes);
    const Eigen::Isometry3d E = P.inverse() * Q;
    rotation[i] = rotation_angle(E.linear()) * kRadToDeg;
    full[i] = (E.matrix() - Eigen::Matrix4d::Identity()).norm();
  }
  ApeResult result;
  result.translation = make_series(std::move(translation));
  result.rotation_deg = make_series(std::move(rotation));
  result.full = make_series(std::move(full));
  result.alignment = aligned.transform;
  result.status = aligned.transform.status;
  return result;
}

std::vector<std::pair<std::size_t, std::size_t>> rpe_pairs(const Trajectory& trajectory, double delta,
                                                           DeltaUnit unit) {
  PLUMB_CHECK(std::isfinite(delta) && delta > 0.0, "rpe_pairs: delta must be > 0, got " << delta);
  std::vector<std::pair<std::size_t, std::size_t>> pairs;
  const std::size_t n = trajectory.size();
  if (unit == DeltaUnit::kFrames) {
    PLUMB_CHECK(delta == std::floor(delta), "rpe_pairs: a frame delta must be an integer, got " << delta);
    const auto step = static_cast<std::size_t>(delta);
    for (std::size_t i = 0; i + step < n; i += step) pairs.emplace_back(i, i + step);
    return pairs;
  }
  std::vector<std::size_t> marks;
  double travelled = 0.0;
  for (std::size_t i = 1; i < n; ++i) {
    travelled += (trajectory.poses[i].translation() - trajectory.poses[i - 1].translation()).norm();
    if (travelled >= delta) {
      marks.push_back(i);
      travelled = 0.0;
    }
  }
  for (std::size_t k = 1; k < marks.size(); ++k) pairs.emplace_back(marks[k - 1], marks[k]);
  return pairs;
}

RpeResult compute_rpe(const Trajectory& estimate, const Trajectory& reference, const RpeSettings& settings) {
  check_paired(estimate, reference, "compute_rpe");
  RpeResult result;
  const Trajectory aligned = align_trajectory(estimate, reference, settings.align).aligned;
  result.pairs = rpe_pairs(settings.pairs_along == PathSource::kReference ? reference : aligned,
                           settings.delta, settings.unit);
  if (result.pairs.empty()) {
    result.status = Status::kInsufficientData;
    return result;
  }
  std::vector<double> translation, rotation, full;
  translation.reserve(result.pairs.size());
  rotation.reserve(result.pairs.size());
  full.reserve(result.pairs.size());
  for (const auto& [i, j] : result.pairs) {
    const Eigen::Isometry3d Q_rel = reference.poses[i].inverse() * reference.poses[j];
    const Eigen::Isometry3d P_rel = aligned.poses[i].inverse() * aligned.poses[j];
    const Eigen::Isometry3d E = Q_rel.inverse() * P_rel;
    translation.push_back(E.translation().norm());
    rotation.push_back(rotation_angle(E.linear()) * kRadToDeg);
    full.push_back((E.matrix() - Eigen::Matrix4d::Identity()).norm());
  }
  result.translation = make_series(std::move(translation));
  result.rotation_deg = make_series(std::move(rotation));
  result.full = make_series(std::move(full));
  return result;
}

std::vector<double> path_lengths(const Trajectory& trajectory, PositionAxes axes) {
  std::vector<double> lengths(trajectory.size(), 0.0);
  for (std::size_t i = 1; i < trajectory.size(); ++i) {
    lengths[i] = lengths[i - 1] + distance(trajectory.poses[i], trajectory.poses[i - 1], axes);
  }
  return lengths;
}

std::vector<DriftSample> drift_at(const Trajectory& estimate, const Trajectory& reference,
                                  const std::vector<std::size_t>& indices, const DriftSettings& settings) {
  check_paired(estimate, reference, "drift_at");
  const std::vector<double> lengths =
      path_lengths(settings.path == PathSource::kReference ? reference : estimate, settings.axes);
  std::vector<DriftSample> samples;
  samples.reserve(indices.size());
  for (std::size_t index : indices) {
    PLUMB_CHECK(index < reference.size(),
                "drift_at: index " << index << " out of range (" << reference.size() << " poses)");
    DriftSample s;
    s.index = index;
    s.path_length = lengths[index];
    s.error = distance(estimate.poses[index], reference.poses[index], settings.axes);
    s.drift_pct = s.path_length > 0.0 ? s.error / s.path_length * 100.0
                                      : std::numeric_limits<double>::quiet_NaN();
    samples.push_back(s);
  }
  return samples;
}

std::size_t nearest_index(const Trajectory& trajectory, double stamp) {
  PLUMB_CHECK(trajectory.has_stamps(), "nearest_index: the trajectory has no stamps");
  return nearest(trajectory.stamps, 0.0, stamp,
                 std::is_sorted(trajectory.stamps.begin(), trajectory.stamps.end()));
}

}  // namespace plumb::eval
