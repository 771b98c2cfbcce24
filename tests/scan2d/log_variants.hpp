// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief A CARMEN log as scan-matching odometry sees it (scans, raw odometry at the scans, the
/// SLAM-corrected poses as the independent reference), the relation error against that reference,
/// and degraded variants of a log that reproduce conditions of real logs: beams at 1 deg instead of
/// 0.5 deg, wheel slip, and an odometry prior that lags (stamps quantised to seconds). Used by the
/// tests and by the accuracy benchmark, so that the figures in docs/results.md and the bounds the
/// tests assert come from the same code.

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "plumb/core/pose2.hpp"
#include "plumb/core/rng.hpp"
#include "plumb/io/carmen.hpp"
#include "plumb/core/laser_scan.hpp"

namespace plumb::test {

/// Scans of a log with their raw odometry poses and corrected (reference) poses.
struct ScanLog {
  std::vector<LaserScan> scans;
  std::vector<Pose2> odometry;   ///< raw wheel odometry interpolated at the scan stamps
  std::vector<Pose2> corrected;  ///< the log's SLAM-corrected poses: the independent reference
};

/// The first `max_scans` FLASER scans of a CARMEN log.
inline ScanLog read_scan_log(const std::string& path,
                             std::size_t max_scans = std::numeric_limits<std::size_t>::max()) {
  const io::CarmenLog log = io::read_carmen(path);
  ScanLog out;
  out.odometry = io::raw_odometry_at_lasers(log);
  for (const auto& l : log.lasers) {
    if (out.scans.size() == max_scans) break;
    out.scans.push_back(l.scan);
    out.corrected.push_back(l.pose);
  }
  out.odometry.resize(out.scans.size());
  return out;
}

struct RelationError {
  double trans_cm = 0.0, rot_deg = 0.0;
};

/// Mean relation error between poses i and i + span of `est` against `ref` (independent of the
/// trajectories' frames): the measure of Kümmerle et al. 2009 used for the CARMEN logs and CSM.
inline RelationError relation_error(const std::vector<Pose2>& est, const std::vector<Pose2>& ref,
                                    std::size_t span) {
  double st = 0.0, sr = 0.0;
  std::size_t n = 0;
  for (std::size_t i = 0; i + span < ref.size() && i + span < est.size(); ++i) {
    const Pose2 a = ref[i].ominus().oplus(ref[i + span]);
    const Pose2 b = est[i].ominus().oplus(est[i + span]);
    const Pose2 e = a.ominus().oplus(b);
    st += std::hypot(e.x, e.y);
    sr += std::abs(wrap_angle(e.theta));
    ++n;
  }
  if (n == 0) return {};
  return {100.0 * st / static_cast<double>(n), 180.0 / 3.14159265358979323846 * sr / static_cast<double>(n)};
}

/// Degraded copies of a log.
enum class LogVariant {
  kOriginal,
  kOneDegree,     ///< every other beam of scans with 300 beams or more (0.5 deg -> 1 deg)
  kSlip,          ///< 5 % of the odometry steps slip by up to 0.15 m and 0.1 rad
  kHeldOdometry,  ///< the odometry pose is updated every 10 s only (stamps quantised to 10 s)
};

inline const char* to_string(LogVariant v) {
  switch (v) {
    case LogVariant::kOriginal: return "original";
    case LogVariant::kOneDegree: return "1deg";
    case LogVariant::kSlip: return "slip";
    case LogVariant::kHeldOdometry: return "held_odometry";
  }
  return "unknown";
}

/// Every other beam, at twice the angle increment, for scans of 300 beams or more.
inline void keep_every_other_beam(std::vector<LaserScan>& scans) {
  for (LaserScan& s : scans) {
    if (s.size() < 300) continue;
    LaserScan d = s;
    d.ranges.clear();
    d.angles.clear();
    for (std::size_t i = 0; i < s.size(); i += 2) {
      d.ranges.push_back(s.ranges[i]);
      if (!s.angles.empty()) d.angles.push_back(s.angles[i]);
    }
    d.angle_increment = 2.0 * s.angle_increment;
    s = std::move(d);
  }
}

/// A fraction of the odometry steps get an extra motion, uniform in +-max_xy per axis and
/// +-max_theta, which stays in all later poses (the wheels slipped; the odometry never learns).
inline void add_slip(std::vector<Pose2>& odometry, double fraction, double max_xy, double max_theta,
                     std::uint64_t seed) {
  if (odometry.size() < 2) return;
  Rng rng(seed);
  std::vector<Pose2> out{odometry.front()};
  for (std::size_t k = 1; k < odometry.size(); ++k) {
    Pose2 step = odometry[k - 1].ominus().oplus(odometry[k]);
    if (rng.uniform() < fraction) {
      step = step.oplus(Pose2{rng.uniform(-max_xy, max_xy), rng.uniform(-max_xy, max_xy),
                              rng.uniform(-max_theta, max_theta)});
    }
    out.push_back(out.back().oplus(step));
  }
  odometry = std::move(out);
}

/// The odometry pose of each scan replaced by the one of the first scan in its `period`-long time
/// bin: the prior stands still for `period` seconds, then jumps.
inline void hold_odometry(std::vector<Pose2>& odometry, const std::vector<LaserScan>& scans, double period) {
  std::size_t first = 0;
  for (std::size_t k = 0; k < odometry.size() && k < scans.size(); ++k) {
    if (std::floor(scans[k].stamp / period) != std::floor(scans[first].stamp / period)) first = k;
    odometry[k] = odometry[first];
  }
}

/// A degraded copy of `log` (deterministic).
inline ScanLog degrade(ScanLog log, LogVariant variant) {
  switch (variant) {
    case LogVariant::kOriginal: break;
    case LogVariant::kOneDegree: keep_every_other_beam(log.scans); break;
    case LogVariant::kSlip: add_slip(log.odometry, 0.05, 0.15, 0.1, 11); break;
    case LogVariant::kHeldOdometry: hold_odometry(log.odometry, log.scans, 10.0); break;
  }
  return log;
}

}  // namespace plumb::test
