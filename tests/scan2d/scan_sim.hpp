// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Test helpers: polygonal 2D worlds ray-cast into LaserScans, and CSM JSON scans.

#include <cmath>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "plumb/core/pose2.hpp"
#include "plumb/core/rng.hpp"
#include "plumb/core/laser_scan.hpp"

namespace plumb::test {

using plumb::kPi;

struct Segment {
  Vector2d a, b;
};

/// Closed polygon as segments.
inline std::vector<Segment> polygon(const std::vector<Vector2d>& v) {
  std::vector<Segment> s;
  for (std::size_t i = 0; i < v.size(); ++i) s.push_back({v[i], v[(i + 1) % v.size()]});
  return s;
}

inline void add_box(std::vector<Segment>& w, double x0, double y0, double x1, double y1) {
  const auto b = polygon({{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}});
  w.insert(w.end(), b.begin(), b.end());
}

/// An L-shaped room 10 m x 8 m with a notch and two boxes: well-conditioned.
inline std::vector<Segment> room_world() {
  auto w = polygon({{-4, -3}, {6, -3}, {6, 2}, {3, 2}, {3, 5}, {-4, 5}});
  add_box(w, 1.0, 0.5, 1.6, 1.2);
  add_box(w, -2.5, -2.0, -1.8, -1.5);
  w.push_back({{4.5, -1.0}, {5.2, -0.3}});  // a slanted panel
  return w;
}

/// Two parallel walls 2 m apart, 200 m long: a corridor without visible ends.
inline std::vector<Segment> corridor_world() {
  return {{{-100, -1}, {100, -1}}, {{-100, 1}, {100, 1}}};
}

/// Ray-cast a scan of n beams over [-fov/2, fov/2] from laser pose T_world_laser; no hit within
/// max_range gives range_max (a no-return reading). Optional Gaussian range noise.
inline LaserScan cast_scan(const std::vector<Segment>& world, const Pose2& T_world_laser, int n,
                           double fov, double range_max = 30.0, double noise = 0.0, Rng* rng = nullptr) {
  LaserScan scan;
  scan.angle_min = -fov / 2;
  scan.angle_increment = fov / (n - 1);
  scan.range_max = range_max;
  scan.ranges.resize(static_cast<std::size_t>(n));
  const Vector2d o(T_world_laser.x, T_world_laser.y);
  for (int i = 0; i < n; ++i) {
    const double a = T_world_laser.theta + scan.angle(static_cast<std::size_t>(i));
    const Vector2d d(std::cos(a), std::sin(a));
    double best = std::numeric_limits<double>::infinity();
    for (const Segment& s : world) {
      const Vector2d e = s.b - s.a;
      const double den = d.x() * (-e.y()) - d.y() * (-e.x());
      if (std::abs(den) < 1e-12) continue;
      const Vector2d r = s.a - o;
      const double t = (r.x() * (-e.y()) - r.y() * (-e.x())) / den;
      const double u = (d.x() * r.y() - d.y() * r.x()) / den;
      if (t > 1e-9 && u >= 0.0 && u <= 1.0) best = std::min(best, t);
    }
    double r = best;
    if (std::isfinite(r) && noise > 0.0 && rng != nullptr) r += noise * rng->normal();
    scan.ranges[static_cast<std::size_t>(i)] =
        static_cast<float>(std::isfinite(best) && best < range_max ? r : range_max);
  }
  return scan;
}

/// One CSM laser_data JSON object (CSM's tests): readings with null = invalid.
struct CsmScan {
  LaserScan scan;
  Pose2 odometry, true_pose;
  bool has_true_pose = false;
};

inline std::vector<CsmScan> read_csm_json(const std::string& path) {
  std::vector<CsmScan> out;
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    if (line.find('{') == std::string::npos) continue;
    const auto j = nlohmann::json::parse(line);
    CsmScan s;
    const auto& th = j.at("theta");
    const auto& rd = j.at("readings");
    const auto& valid = j.at("valid");
    for (std::size_t i = 0; i < th.size(); ++i) {
      s.scan.angles.push_back(static_cast<float>(th[i].get<double>()));
      const bool ok = !rd[i].is_null() && valid[i].get<int>() != 0;
      s.scan.ranges.push_back(ok ? static_cast<float>(rd[i].get<double>())
                                 : std::numeric_limits<float>::quiet_NaN());
    }
    const auto& od = j.at("odometry");
    s.odometry = {od[0].get<double>(), od[1].get<double>(), od[2].get<double>()};
    if (j.contains("true_pose") && !j["true_pose"][0].is_null()) {
      const auto& tp = j["true_pose"];
      s.true_pose = {tp[0].get<double>(), tp[1].get<double>(), tp[2].get<double>()};
      s.has_true_pose = true;
    }
    out.push_back(std::move(s));
  }
  return out;
}

}  // namespace plumb::test
