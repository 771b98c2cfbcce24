// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/segmentation/presegment.hpp"

#include <algorithm>
#include <cmath>

#include "plumb/core/error.hpp"

namespace plumb {
namespace {

/// The clamped cosine whose arccos is normal_axis_angle(), or NaN.
inline double normal_axis_cos(const Vector3f& n, const Vector3d& axis) {
  const Vector3d nd = n.cast<double>();
  const double denom = nd.norm() * axis.norm();
  if (!(denom > 0.0) || !std::isfinite(denom)) return std::numeric_limits<double>::quiet_NaN();
  const double c = nd.dot(axis) / denom;
  return std::max(-1.0, std::min(1.0, c));
}

/// The cosine (in [0, 1]) whose arccos is vertical_u_angle(), or NaN.
inline double vertical_u_cos(const Vector3f& n) {
  const Vector3d nd = n.cast<double>();
  if (!nd.allFinite()) return std::numeric_limits<double>::quiet_NaN();
  const Vector3d u1 = nd.cross(Vector3d::UnitX());
  const Vector3d u2 = nd.cross(Vector3d::UnitY());
  const Vector3d& u = u1.squaredNorm() >= u2.squaredNorm() ? u1 : u2;
  const double len = u.norm();
  if (!(len > 0.0)) return std::numeric_limits<double>::quiet_NaN();
  return std::min(1.0, std::abs(u.z()) / len);
}

/// Whether acos(c) lies in [lo, hi] (c in [-1, 1] or NaN), without arccos away from the window's
/// edges: acos decreases with a slope of magnitude >= 1, so for lo, hi inside (0, pi) a c farther
/// than 1e-9 from cos(lo) and cos(hi) is decided by comparing cosines. Cosines within that band,
/// and windows with an edge at or beyond 0 or pi (other than lo <= 0), take the arccos as before.
class AngleWindow {
 public:
  AngleWindow(double lo, double hi) : lo_(lo), hi_(hi), cos_lo_(std::cos(lo)), cos_hi_(std::cos(hi)) {
    constexpr double kPiBelow = 3.141592653589;  // edges closer to pi than this take the arccos
    lo_free_ = lo <= 0.0;                        // theta >= lo always (acos >= 0)
    fast_ = (lo_free_ || lo < kPiBelow) && hi > 0.0 && hi < kPiBelow && lo <= hi;
  }
  bool contains(double c) const {
    if (!(c == c)) return false;  // NaN: no angle
    constexpr double kBand = 1e-9;
    if (!fast_ || (!lo_free_ && std::abs(c - cos_lo_) <= kBand) || std::abs(c - cos_hi_) <= kBand) {
      const double theta = std::acos(c);
      return theta >= lo_ && theta <= hi_;
    }
    // theta >= lo <=> c < cos(lo); theta <= hi <=> c > cos(hi) (outside the bands).
    return (lo_free_ || c < cos_lo_) && c > cos_hi_;
  }

 private:
  double lo_, hi_, cos_lo_, cos_hi_;
  bool lo_free_ = false, fast_ = false;
};

}  // namespace

double normal_axis_angle(const Vector3f& n, const Vector3d& axis) { return std::acos(normal_axis_cos(n, axis)); }

double projection_length(const Vector3f& q, const Vector3f& n) {
  const Vector3d nd = n.cast<double>();
  const double len = nd.norm();
  if (!(len > 0.0) || !std::isfinite(len)) return std::numeric_limits<double>::quiet_NaN();
  return std::abs(nd.dot(q.cast<double>())) / len;
}

double vertical_u_angle(const Vector3f& n) { return std::acos(vertical_u_cos(n)); }

std::vector<std::size_t> presegment(const std::vector<Vector3f>& points, const std::vector<Vector3f>& normals,
                                    const PresegmentSettings& settings) {
  PLUMB_CHECK(points.size() == normals.size(), "presegment: " << normals.size() << " normals for "
                                                              << points.size() << " points");
  PLUMB_CHECK(settings.axis.allFinite() && settings.axis.norm() > 0.0,
              "presegment: settings.axis must be finite and non-zero");
  PLUMB_CHECK(!std::isnan(settings.min_angle) && !std::isnan(settings.max_angle) &&
                  !std::isnan(settings.min_length) && !std::isnan(settings.max_length),
              "presegment: NaN threshold in settings");
  std::vector<std::size_t> out;
  // The angle window is tested on cosines (the same decisions as on the angles, see AngleWindow).
  const AngleWindow window(settings.min_angle, settings.max_angle);
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Vector3f& n = normals[i];
    if (!n.allFinite() || !points[i].allFinite()) continue;
    const double c = settings.angle_kind == PresegmentAngle::kNormalToAxis ? normal_axis_cos(n, settings.axis)
                                                                           : vertical_u_cos(n);
    if (!window.contains(c)) continue;
    const double l = projection_length(points[i], n);
    if (!(l >= settings.min_length && l <= settings.max_length)) continue;
    out.push_back(i);
  }
  return out;
}

}  // namespace plumb
