// SPDX-License-Identifier: BSD-3-Clause
// Tuples from scans + wheel encoders: a simulated robot with piecewise-constant wheel speeds,
// encoders sampled at 100 Hz, scans at other times, and a stand-in scan matcher that returns the
// true laser motion from the simulated poses. Extraction followed by calibration must recover
// the simulated parameters.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>
#include <vector>

#include <gtest/gtest.h>

#include "plumb/calibration/tuple_extraction.hpp"
#include "plumb/core/error.hpp"
#include "plumb/core/rng.hpp"

namespace {

using plumb::LaserScan;
using plumb::OdometryLaserParams;
using plumb::Pose2;
using plumb::WheelEncoderReading;

const OdometryLaserParams kTrueParams{0.05, 0.0502, 0.32, Pose2{0.12, -0.03, 0.4}};
constexpr double kSegment = 0.8;  // wheel speeds change every 0.8 s (on the encoder grid)

struct Sim {
  std::vector<double> phi_l, phi_r;  // per segment [rad/s]
  double duration = 0.0;

  int segment(double t) const { return std::min(static_cast<int>(std::floor(t / kSegment)), static_cast<int>(phi_l.size()) - 1); }

  /// Cumulative wheel angles at t.
  plumb::Vector2d wheel_angles(double t) const {
    plumb::Vector2d a(0, 0);
    for (int s = 0; s < static_cast<int>(phi_l.size()); ++s) {
      const double t0 = s * kSegment, dt = std::clamp(t - t0, 0.0, kSegment);
      a += dt * plumb::Vector2d(phi_l[s], phi_r[s]);
    }
    return a;
  }

  /// Robot pose at t: exact arcs per segment composed with ⊕ (circle geometry, not the library).
  Pose2 pose(double t) const {
    Pose2 q;
    for (int s = 0; s < static_cast<int>(phi_l.size()); ++s) {
      const double t0 = s * kSegment, dt = std::clamp(t - t0, 0.0, kSegment);
      if (dt <= 0.0) break;
      const double vl = kTrueParams.radius_left * phi_l[s], vr = kTrueParams.radius_right * phi_r[s];
      const double v = 0.5 * (vl + vr), w = (vr - vl) / kTrueParams.axle, th = w * dt;
      const Pose2 r = std::abs(w) < 1e-15 ? Pose2{v * dt, 0, 0}
                                          : Pose2{v / w * std::sin(th), v / w * (1 - std::cos(th)), th};
      q = q.oplus(r);
    }
    return q;
  }
};

Sim make_sim(int segments, std::uint64_t seed) {
  plumb::Rng rng(seed);
  Sim sim;
  for (int s = 0; s < segments; ++s) {
    const double a = rng.uniform(-2.0, 2.0);
    switch (s % 3) {
      case 0: sim.phi_l.push_back(a); sim.phi_r.push_back(-a); break;          // spin
      case 1: sim.phi_l.push_back(a); sim.phi_r.push_back(a * 0.9); break;     // nearly straight
      default: sim.phi_l.push_back(a); sim.phi_r.push_back(rng.uniform(-2.0, 2.0)); break;  // arc
    }
  }
  sim.duration = segments * kSegment;
  return sim;
}

std::vector<WheelEncoderReading> encoders(const Sim& sim) {
  std::vector<WheelEncoderReading> w;
  for (int i = 0; 0.01 * i <= sim.duration + 1e-9; ++i) {
    const double t = 0.01 * i;
    const plumb::Vector2d a = sim.wheel_angles(t);
    w.push_back({t, a(0), a(1)});
  }
  return w;
}

/// Two scans per segment, off the encoder grid, the first pair inside one segment.
std::vector<LaserScan> scans(const Sim& sim) {
  std::vector<LaserScan> out;
  for (std::size_t s = 0; s < sim.phi_l.size(); ++s) {
    for (const double offset : {0.0537, 0.7537}) {
      LaserScan scan;
      scan.stamp = s * kSegment + offset;
      out.push_back(scan);
    }
  }
  return out;
}

TEST(WheelEncoderTest, InterpolationAndTicks) {
  const std::vector<WheelEncoderReading> w = {{1.0, 0.0, 10.0}, {2.0, 1.0, 8.0}, {5.0, 2.0, 0.0}};
  EXPECT_FALSE(plumb::interpolate_wheel_angles(w, 0.99, 1.0));
  EXPECT_FALSE(plumb::interpolate_wheel_angles(w, 5.01, 1.0));
  EXPECT_FALSE(plumb::interpolate_wheel_angles(w, 3.0, 1.0));  // inside a 3 s gap
  EXPECT_FALSE(plumb::interpolate_wheel_angles({}, 1.0, 1.0));
  const auto a = plumb::interpolate_wheel_angles(w, 1.25, 1.0);
  ASSERT_TRUE(a);
  EXPECT_DOUBLE_EQ((*a)(0), 0.25);
  EXPECT_DOUBLE_EQ((*a)(1), 9.5);
  const auto b = plumb::interpolate_wheel_angles(w, 5.0, 1.0);  // exactly on the last reading
  ASSERT_TRUE(b);
  EXPECT_EQ((*b)(0), 2.0);
  const auto c = plumb::interpolate_wheel_angles(w, 3.0, 3.0);
  ASSERT_TRUE(c);
  EXPECT_DOUBLE_EQ((*c)(1), 8.0 - 8.0 / 3.0);
  const WheelEncoderReading t = WheelEncoderReading::from_ticks(2.0, 512, -1024, 2048);
  EXPECT_DOUBLE_EQ(t.left, M_PI / 2);
  EXPECT_DOUBLE_EQ(t.right, -M_PI);
  EXPECT_THROW(WheelEncoderReading::from_ticks(0, 1, 1, 0), plumb::Error);
}

TEST(TupleExtractionTest, ExtractedTuplesCalibrateToTruth) {
  const Sim sim = make_sim(60, 3);
  const auto wheels = encoders(sim);
  const auto log_scans = scans(sim);
  std::size_t calls = 0;
  double max_guess_error = 0.0;
  // Stand-in matcher: the true laser motion, refused when the pair straddles a speed change
  // (there the constant-speed tuple model is not exact). The extractor's own constant-speed check
  // should drop those pairs before they reach the matcher.
  const plumb::ScanMatcher matcher = [&](const LaserScan& ref, const LaserScan& cur,
                                         const Pose2& guess) -> std::optional<Pose2> {
    ++calls;
    if (sim.segment(ref.stamp) != sim.segment(cur.stamp)) return std::nullopt;
    const Pose2 r = sim.pose(ref.stamp).ominus().oplus(sim.pose(cur.stamp));
    const Pose2 s = kTrueParams.laser.ominus().oplus(r).oplus(kTrueParams.laser);
    max_guess_error = std::max(max_guess_error, (s.vector() - guess.vector()).cwiseAbs().maxCoeff());
    return s;
  };
  plumb::TupleExtractionSettings settings;
  settings.nominal = kTrueParams;  // then the guess is the true motion
  const auto ex = plumb::extract_calibration_tuples(log_scans, wheels, matcher, settings);
  ASSERT_EQ(ex.status, plumb::Status::kOk);
  EXPECT_EQ(ex.num_pairs, log_scans.size() - 1);
  EXPECT_EQ(calls, ex.num_pairs - ex.num_speed_changes);
  EXPECT_EQ(ex.num_without_odometry, 0u);
  EXPECT_EQ(ex.num_speed_changes + ex.num_match_failures, sim.phi_l.size() - 1);  // every straddling pair
  EXPECT_GE(ex.num_speed_changes + 2, sim.phi_l.size() - 1);  // (almost) all caught by the speed check
  ASSERT_EQ(ex.tuples.size(), sim.phi_l.size());
  EXPECT_LT(max_guess_error, 1e-12);
  for (std::size_t i = 0; i < ex.tuples.size(); ++i) {
    EXPECT_NEAR(ex.tuples[i].T, 0.7, 1e-12);
    EXPECT_NEAR(ex.tuples[i].phi_left, sim.phi_l[i], 1e-9);
    EXPECT_NEAR(ex.tuples[i].phi_right, sim.phi_r[i], 1e-9);
    EXPECT_EQ(ex.scan_pairs[i].first, 2 * i);
    EXPECT_EQ(ex.scan_pairs[i].second, 2 * i + 1);
  }
  const auto est = plumb::calibrate_odometry_laser(ex.tuples);
  ASSERT_EQ(est.status, plumb::Status::kOk);
  EXPECT_LT((est.params.vector() - kTrueParams.vector()).cwiseAbs().maxCoeff(), 1e-9);
}

TEST(TupleExtractionTest, SpacedPairsAndEncoderGaps) {
  const Sim sim = make_sim(12, 4);
  auto wheels = encoders(sim);
  // Remove the readings of (2.0, 3.0) s: scans in that gap get no odometry.
  std::vector<WheelEncoderReading> gappy;
  for (const auto& w : wheels)
    if (!(w.stamp > 2.0 && w.stamp < 3.0)) gappy.push_back(w);
  const auto log_scans = scans(sim);
  const plumb::ScanMatcher identity = [](const LaserScan&, const LaserScan&, const Pose2& g) {
    return std::optional<Pose2>(g);
  };
  plumb::TupleExtractionSettings settings;
  settings.scan_spacing = 2;
  settings.check_constant_speed = false;  // here every pair should reach the matcher
  const auto ex = plumb::extract_calibration_tuples(log_scans, gappy, identity, settings);
  EXPECT_EQ(ex.num_pairs, log_scans.size() - 2);
  std::size_t expected_missing = 0;
  for (std::size_t k = 0; k + 2 < log_scans.size(); ++k) {
    auto in_gap = [](double t) { return t > 2.0 && t < 3.0; };
    if (in_gap(log_scans[k].stamp) || in_gap(log_scans[k + 2].stamp)) ++expected_missing;
  }
  EXPECT_GT(expected_missing, 0u);
  EXPECT_EQ(ex.num_without_odometry, expected_missing);
  EXPECT_EQ(ex.tuples.size(), ex.num_pairs - expected_missing);
  for (const auto& p : ex.scan_pairs) EXPECT_EQ(p.second, p.first + 2);
  // Without nominal parameters the guess is the identity.
  for (const auto& t : ex.tuples) EXPECT_EQ(t.laser_motion.vector(), plumb::Vector3d::Zero());
}

TEST(TupleExtractionTest, BadInputThrowsOrReportsNoTuples) {
  const Sim sim = make_sim(3, 5);
  const auto wheels = encoders(sim);
  auto log_scans = scans(sim);
  const plumb::ScanMatcher fail = [](const LaserScan&, const LaserScan&, const Pose2&) {
    return std::optional<Pose2>();
  };
  plumb::TupleExtractionSettings no_check;
  no_check.check_constant_speed = false;
  const auto none = plumb::extract_calibration_tuples(log_scans, wheels, fail, no_check);
  EXPECT_EQ(none.status, plumb::Status::kInsufficientData);
  EXPECT_EQ(none.num_match_failures, none.num_pairs);
  plumb::TupleExtractionSettings negative;
  negative.max_speed_change = -1.0;
  EXPECT_THROW(plumb::extract_calibration_tuples(log_scans, wheels, fail, negative), plumb::Error);
  EXPECT_EQ(plumb::extract_calibration_tuples({}, wheels, fail).status, plumb::Status::kInsufficientData);
  auto unsorted = log_scans;
  std::swap(unsorted[1].stamp, unsorted[2].stamp);
  EXPECT_THROW(plumb::extract_calibration_tuples(unsorted, wheels, fail), plumb::Error);
  auto bad_wheels = wheels;
  bad_wheels[4].stamp = bad_wheels[3].stamp;
  EXPECT_THROW(plumb::extract_calibration_tuples(log_scans, bad_wheels, fail), plumb::Error);
  plumb::TupleExtractionSettings zero;
  zero.scan_spacing = 0;
  EXPECT_THROW(plumb::extract_calibration_tuples(log_scans, wheels, fail, zero), plumb::Error);
  EXPECT_THROW(plumb::extract_calibration_tuples(log_scans, wheels, plumb::ScanMatcher{}), plumb::Error);
}

}  // namespace

namespace {

/// Ray-cast a 360-beam scan in a room (walls and a few boxes) from a laser pose in the world.
LaserScan cast_scan(const Pose2& T_world_laser, double stamp) {
  struct Seg {
    plumb::Vector2d a, b;
  };
  static const std::vector<Seg> walls = [] {
    std::vector<Seg> w;
    auto poly = [&w](std::vector<plumb::Vector2d> p) {
      for (std::size_t i = 0; i < p.size(); ++i) w.push_back({p[i], p[(i + 1) % p.size()]});
    };
    poly({{-4, -3}, {5, -3}, {5, 4}, {-4, 4}});
    poly({{1.5, 1.0}, {2.2, 1.0}, {2.2, 1.6}, {1.5, 1.6}});
    poly({{-2.5, -1.8}, {-1.9, -1.8}, {-1.9, -0.9}, {-2.5, -0.9}});
    poly({{2.5, -2.0}, {3.4, -1.2}, {3.0, -0.8}});
    return w;
  }();
  LaserScan scan;
  scan.stamp = stamp;
  scan.angle_min = -M_PI;
  scan.angle_increment = 2 * M_PI / 360;
  scan.range_max = 30.0;
  scan.range_min = 0.05;
  const plumb::Vector2d o(T_world_laser.x, T_world_laser.y);
  for (int i = 0; i < 360; ++i) {
    const double a = T_world_laser.theta + scan.angle(static_cast<std::size_t>(i));
    const plumb::Vector2d d(std::cos(a), std::sin(a));
    double best = std::numeric_limits<double>::infinity();
    for (const Seg& s : walls) {
      const plumb::Vector2d e = s.b - s.a;
      const double den = d.x() * (-e.y()) - d.y() * (-e.x());
      if (std::abs(den) < 1e-12) continue;
      const plumb::Vector2d w = s.a - o;
      const double t = (w.x() * (-e.y()) - w.y() * (-e.x())) / den;
      const double u = (d.x() * w.y() - d.y() * w.x()) / den;
      if (t > 0 && u >= 0 && u <= 1) best = std::min(best, t);
    }
    scan.ranges.push_back(static_cast<float>(best));
  }
  return scan;
}

TEST(TupleExtractionTest, PlicpTuplesFromSimulatedRoomCalibrate) {
  const Sim sim = make_sim(45, 9);
  const auto wheels = encoders(sim);
  std::vector<LaserScan> log_scans;
  for (const LaserScan& s : scans(sim)) {
    // Start near the room's middle; the laser sees the walls and boxes.
    const Pose2 q = Pose2{0.3, 0.2, 0.1}.oplus(sim.pose(s.stamp));
    log_scans.push_back(cast_scan(q.oplus(kTrueParams.laser), s.stamp));
  }
  // Nominal parameters a few percent off, as a user would know them.
  plumb::TupleExtractionSettings settings;
  settings.nominal = {0.048, 0.052, 0.33, Pose2{0.1, 0.0, 0.35}};
  const plumb::ScanMatcher base = plumb::plicp_scan_matcher();
  // Only the pairs inside one speed segment follow the constant-speed tuple model.
  const plumb::ScanMatcher matcher = [&](const LaserScan& a, const LaserScan& b, const Pose2& g) {
    return sim.segment(a.stamp) == sim.segment(b.stamp) ? base(a, b, g) : std::nullopt;
  };
  const auto ex = plumb::extract_calibration_tuples(log_scans, wheels, matcher, settings);
  ASSERT_EQ(ex.status, plumb::Status::kOk);
  EXPECT_GE(ex.tuples.size(), sim.phi_l.size() - 3);  // PLICP matched (almost) every pair
  const auto est = plumb::calibrate_odometry_laser(ex.tuples);
  ASSERT_EQ(est.status, plumb::Status::kOk);
  const plumb::Vector6d err = est.params.vector() - kTrueParams.vector();
  // Noise-free scans of straight walls: PLICP's point-to-line solution is exact up to its
  // stopping tolerance, so the whole chain recovers the parameters to ~1e-8.
  for (int j = 0; j < 6; ++j) EXPECT_LT(std::abs(err(j)), 1e-6) << "parameter " << j;
}

}  // namespace
