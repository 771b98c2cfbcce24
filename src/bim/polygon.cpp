// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/bim/polygon.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

namespace plumb::bim {

namespace {

double cross(const Vector2d& o, const Vector2d& a, const Vector2d& b) {
  return (a.x() - o.x()) * (b.y() - o.y()) - (a.y() - o.y()) * (b.x() - o.x());
}

/// Segments p1-p2 and q1-q2 cross in their interiors (touching at endpoints does not count).
bool segments_cross(const Vector2d& p1, const Vector2d& p2, const Vector2d& q1, const Vector2d& q2, double eps) {
  const double d1 = cross(q1, q2, p1);
  const double d2 = cross(q1, q2, p2);
  const double d3 = cross(p1, p2, q1);
  const double d4 = cross(p1, p2, q2);
  return ((d1 > eps && d2 < -eps) || (d1 < -eps && d2 > eps)) && ((d3 > eps && d4 < -eps) || (d3 < -eps && d4 > eps));
}

bool in_triangle(const Vector2d& p, const Vector2d& a, const Vector2d& b, const Vector2d& c, double eps) {
  return cross(a, b, p) >= -eps && cross(b, c, p) >= -eps && cross(c, a, p) >= -eps;
}

/// Bridges hole `h` (clockwise) into the outer loop `poly` from the hole's rightmost vertex to the
/// nearest loop vertex it sees, preferring those not left of it. Leaves `poly` as it is when it sees
/// none (the hole is dropped).
void bridge_hole(std::vector<std::uint32_t>& poly, const std::vector<std::uint32_t>& h,
                 const std::vector<Vector2d>& pts, double eps) {
  std::size_t m = 0;
  for (std::size_t i = 1; i < h.size(); ++i) {
    if (pts[h[i]].x() > pts[h[m]].x()) m = i;
  }
  const Vector2d& M = pts[h[m]];
  auto visible = [&](std::uint32_t pi) {
    const Vector2d& P = pts[pi];
    for (std::size_t i = 0; i < poly.size(); ++i) {
      const Vector2d& a = pts[poly[i]];
      const Vector2d& b = pts[poly[(i + 1) % poly.size()]];
      if (segments_cross(M, P, a, b, eps)) return false;
    }
    for (std::size_t i = 0; i < h.size(); ++i) {
      const Vector2d& a = pts[h[i]];
      const Vector2d& b = pts[h[(i + 1) % h.size()]];
      if (segments_cross(M, P, a, b, eps)) return false;
    }
    return true;
  };
  std::size_t best = poly.size();
  double best_d = std::numeric_limits<double>::infinity();
  for (int pass = 0; pass < 2 && best == poly.size(); ++pass) {
    for (std::size_t i = 0; i < poly.size(); ++i) {
      const Vector2d& P = pts[poly[i]];
      if (pass == 0 && P.x() < M.x()) continue;
      const double d = (P - M).squaredNorm();
      if (d < best_d && visible(poly[i])) {
        best_d = d;
        best = i;
      }
    }
  }
  if (best == poly.size()) return;  // cannot bridge: drop the hole
  std::vector<std::uint32_t> merged;
  merged.reserve(poly.size() + h.size() + 2);
  merged.insert(merged.end(), poly.begin(), poly.begin() + static_cast<std::ptrdiff_t>(best) + 1);
  for (std::size_t k = 0; k <= h.size(); ++k) merged.push_back(h[(m + k) % h.size()]);
  merged.push_back(poly[best]);
  merged.insert(merged.end(), poly.begin() + static_cast<std::ptrdiff_t>(best) + 1, poly.end());
  poly.swap(merged);
}

/// One step of ear clipping from vertex `cursor` on: drops the first collinear vertex or clips the
/// first ear met. Returns false when the polygon has neither.
bool clip_ear(std::vector<std::uint32_t>& poly, const std::vector<Vector2d>& pts, double eps, std::size_t& cursor,
              std::vector<std::array<std::uint32_t, 3>>& tris) {
  const std::size_t n = poly.size();
  for (std::size_t k = 0; k < n; ++k) {
    const std::size_t i = (cursor + k) % n;
    const std::uint32_t ia = poly[(i + n - 1) % n];
    const std::uint32_t ib = poly[i];
    const std::uint32_t ic = poly[(i + 1) % n];
    const Vector2d& a = pts[ia];
    const Vector2d& b = pts[ib];
    const Vector2d& c = pts[ic];
    const double cr = cross(a, b, c);
    if (std::abs(cr) <= eps) {  // collinear / duplicate vertex: drop it
      poly.erase(poly.begin() + static_cast<std::ptrdiff_t>(i));
      cursor = i;
      return true;
    }
    if (cr < 0.0) continue;  // reflex
    bool ear = true;
    for (std::size_t j = 0; j < n && ear; ++j) {
      const std::uint32_t ip = poly[j];
      if (ip == ia || ip == ib || ip == ic) continue;
      const Vector2d& p = pts[ip];
      if (p == a || p == b || p == c) continue;  // bridge duplicates
      if (in_triangle(p, a, b, c, -eps)) ear = false;
    }
    if (!ear) continue;
    tris.push_back({ia, ib, ic});
    poly.erase(poly.begin() + static_cast<std::ptrdiff_t>(i));
    cursor = i;
    return true;
  }
  return false;
}

/// No ear (self-intersecting input): clip the most convex vertex to make progress.
void clip_most_convex(std::vector<std::uint32_t>& poly, const std::vector<Vector2d>& pts, double eps,
                      std::vector<std::array<std::uint32_t, 3>>& tris) {
  const std::size_t n = poly.size();
  std::size_t bi = 0;
  double bc = -std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < n; ++i) {
    const double cr = cross(pts[poly[(i + n - 1) % n]], pts[poly[i]], pts[poly[(i + 1) % n]]);
    if (cr > bc) {
      bc = cr;
      bi = i;
    }
  }
  if (bc > eps) tris.push_back({poly[(bi + n - 1) % n], poly[bi], poly[(bi + 1) % n]});
  poly.erase(poly.begin() + static_cast<std::ptrdiff_t>(bi));
}

}  // namespace

double signed_area(const std::vector<Vector2d>& loop) {
  double a = 0.0;
  const std::size_t n = loop.size();
  for (std::size_t i = 0; i < n; ++i) {
    const Vector2d& p = loop[i];
    const Vector2d& q = loop[(i + 1) % n];
    a += p.x() * q.y() - q.x() * p.y();
  }
  return 0.5 * a;
}

bool point_in_loops(const Vector2d& p, const std::vector<std::vector<Vector2d>>& loops) {
  bool inside = false;
  for (const auto& loop : loops) {
    const std::size_t n = loop.size();
    for (std::size_t i = 0, j = n - 1; i < n; j = i++) {
      const Vector2d& a = loop[i];
      const Vector2d& b = loop[j];
      if ((a.y() > p.y()) != (b.y() > p.y())) {
        const double x = a.x() + (p.y() - a.y()) * (b.x() - a.x()) / (b.y() - a.y());
        if (p.x() < x) inside = !inside;
      }
    }
  }
  return inside;
}

std::vector<std::array<std::uint32_t, 3>> triangulate_polygon(const std::vector<std::vector<Vector2d>>& loops) {
  std::vector<std::array<std::uint32_t, 3>> tris;
  if (loops.empty() || loops[0].size() < 3) return tris;
  // Flatten points; keep per-loop index lists.
  std::vector<Vector2d> pts;
  std::vector<std::vector<std::uint32_t>> idx(loops.size());
  Vector2d lo = Vector2d::Constant(std::numeric_limits<double>::infinity());
  Vector2d hi = -lo;
  for (std::size_t l = 0; l < loops.size(); ++l) {
    for (const auto& p : loops[l]) {
      idx[l].push_back(static_cast<std::uint32_t>(pts.size()));
      pts.push_back(p);
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
  }
  const double diag = (hi - lo).norm();
  if (!std::isfinite(diag) || diag <= 0.0) return tris;
  const double eps = 1e-12 * diag * diag;

  std::vector<std::uint32_t> poly = idx[0];
  if (signed_area(loops[0]) < 0.0) std::reverse(poly.begin(), poly.end());

  // Holes: clockwise, processed by decreasing max x, each bridged from its rightmost vertex.
  std::vector<std::size_t> holes;
  for (std::size_t l = 1; l < loops.size(); ++l) {
    if (loops[l].size() >= 3) holes.push_back(l);
  }
  auto max_x = [&](std::size_t l) {
    double m = -std::numeric_limits<double>::infinity();
    for (const auto& p : loops[l]) m = std::max(m, p.x());
    return m;
  };
  std::sort(holes.begin(), holes.end(), [&](std::size_t a, std::size_t b) { return max_x(a) > max_x(b); });
  for (std::size_t l : holes) {
    std::vector<std::uint32_t> h = idx[l];
    if (signed_area(loops[l]) > 0.0) std::reverse(h.begin(), h.end());
    bridge_hole(poly, h, pts, eps);
  }

  // Ear clipping.
  std::size_t guard = 0;
  std::size_t cursor = 0;
  while (poly.size() > 3 && guard++ < 100000) {
    if (!clip_ear(poly, pts, eps, cursor, tris)) clip_most_convex(poly, pts, eps, tris);
  }
  if (poly.size() == 3 && cross(pts[poly[0]], pts[poly[1]], pts[poly[2]]) > eps) {
    tris.push_back({poly[0], poly[1], poly[2]});
  }
  return tris;
}

}  // namespace plumb::bim
