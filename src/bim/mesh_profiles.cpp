// SPDX-License-Identifier: BSD-3-Clause
// The Builder's 2D geometry: curves (polylines, indexed poly curves with arcs, composite and trimmed
// curves, circles and ellipses) as point loops, arcs cut into BimMeshSettings::circle_segments per turn,
// and the profile definitions a swept solid or a bounded half-space is made of.
#include "mesh_builder.hpp"

#include <algorithm>
#include <cmath>

namespace plumb::bim::mesh_detail {

int Builder::arc_segments(double sweep) const {
  const double per = 2.0 * kPi / std::max(3, settings_.circle_segments);
  return std::max(2, static_cast<int>(std::ceil(std::abs(sweep) / per - 1e-9)));
}

void Builder::push_unique(Loop2& out, const Vector2d& p) {
  if (out.empty() || (out.back() - p).squaredNorm() > 1e-24) out.push_back(p);
}

void Builder::arc_points(const Vector2d& c, double r, double a0, double a1, Loop2& out) const {
  const int n = arc_segments(a1 - a0);
  for (int k = 0; k <= n; ++k) {
    const double a = a0 + (a1 - a0) * k / n;
    push_unique(out, c + r * Vector2d(std::cos(a), std::sin(a)));
  }
}

void Builder::curve(std::uint32_t id, Loop2& out, int depth) {
  check_depth(id, depth);
  const std::string& t = f_.type_of(id);
  if (t == "IFCPOLYLINE") {
    const Args a = args_of(id, 1);
    if (!a[0].is_list()) fail(id, "expects a list of points");
    for (const auto& p : a[0].items) {
      const Vector3d q = point3(ref(p, id, "point"));
      push_unique(out, q.head<2>());
    }
  } else if (t == "IFCINDEXEDPOLYCURVE") {
    const Args a = args_of(id, 1);
    const Args pl = args_of(ref(a[0], id, "Points"), 1);
    if (!pl[0].is_list()) fail(id, "point list expected");
    std::vector<Vector2d> pts;
    for (const auto& c : pl[0].items) {
      if (!c.is_list() || c.items.size() < 2) fail(id, "bad coordinate in point list");
      pts.emplace_back(num(c.items[0], id, "x"), num(c.items[1], id, "y"));
    }
    auto at = [&](const StepValue& v) -> const Vector2d& {
      const double k = v.number();
      if (!(k >= 1 && k <= static_cast<double>(pts.size()))) fail(id, "segment index out of range");
      return pts[static_cast<std::size_t>(k) - 1];
    };
    if (a.size() < 2 || a[1].is_null()) {
      for (const auto& p : pts) push_unique(out, p);
    } else {
      if (!a[1].is_list()) fail(id, "Segments must be a list");
      for (const auto& seg : a[1].items) {
        if (seg.kind != StepValue::Kind::kTyped || seg.items.empty() || !seg.items[0].is_list()) {
          fail(id, "bad segment");
        }
        const auto& ix = seg.items[0].items;
        if (seg.text == "IFCARCINDEX" && ix.size() == 3) {
          const Vector2d p1 = at(ix[0]), p2 = at(ix[1]), p3 = at(ix[2]);
          three_point_arc(p1, p2, p3, out);
        } else {
          for (const auto& k : ix) push_unique(out, at(k));
        }
      }
    }
  } else if (t == "IFCCOMPOSITECURVE") {
    const Args a = args_of(id, 1);
    if (!a[0].is_list()) fail(id, "expects a list of segments");
    for (const auto& s : a[0].items) {
      const std::uint32_t sid = ref(s, id, "segment");
      const Args sa = args_of(sid, 3);
      Loop2 part;
      curve(ref(sa[2], sid, "ParentCurve"), part, depth + 1);
      if (sa[1].kind == StepValue::Kind::kEnum && sa[1].text == "F") std::reverse(part.begin(), part.end());
      for (const auto& p : part) push_unique(out, p);
    }
  } else if (t == "IFCTRIMMEDCURVE") {
    trimmed_curve(id, out, depth);
  } else if (t == "IFCCIRCLE") {
    const Args a = args_of(id, 2);
    const Affine P = axis_placement(a[0], id);
    const double r = num(a[1], id, "Radius");
    Loop2 local;
    arc_points(Vector2d::Zero(), r, 0.0, 2.0 * kPi, local);
    local.pop_back();
    for (const auto& p : local) push_unique(out, (P * Vector3d(p.x(), p.y(), 0)).head<2>());
  } else {
    unsupported(id);
    fail(id, "unsupported curve type");
  }
}

void Builder::three_point_arc(const Vector2d& p1, const Vector2d& p2, const Vector2d& p3, Loop2& out) const {
  const double d = 2.0 * (p1.x() * (p2.y() - p3.y()) + p2.x() * (p3.y() - p1.y()) + p3.x() * (p1.y() - p2.y()));
  if (std::abs(d) < 1e-18) {
    push_unique(out, p1);
    push_unique(out, p3);
    return;
  }
  const double s1 = p1.squaredNorm(), s2 = p2.squaredNorm(), s3 = p3.squaredNorm();
  const Vector2d c((s1 * (p2.y() - p3.y()) + s2 * (p3.y() - p1.y()) + s3 * (p1.y() - p2.y())) / d,
                   (s1 * (p3.x() - p2.x()) + s2 * (p1.x() - p3.x()) + s3 * (p2.x() - p1.x())) / d);
  const double r = (p1 - c).norm();
  const double a1 = std::atan2(p1.y() - c.y(), p1.x() - c.x());
  double a2 = std::atan2(p2.y() - c.y(), p2.x() - c.x());
  double a3 = std::atan2(p3.y() - c.y(), p3.x() - c.x());
  // Counter-clockwise when p2 lies on the ccw sweep from p1 to p3.
  auto ccw_delta = [](double from, double to) {
    double x = to - from;
    while (x < 0) x += 2 * kPi;
    return x;
  };
  if (ccw_delta(a1, a2) <= ccw_delta(a1, a3)) {
    a3 = a1 + ccw_delta(a1, a3);
  } else {
    a3 = a1 - ccw_delta(a3, a1);
  }
  (void)a2;
  arc_points(c, r, a1, a3, out);
}

void Builder::trimmed_curve(std::uint32_t id, Loop2& out, int depth) {
  const Args a = args_of(id, 5);
  const std::uint32_t basis = ref(a[0], id, "BasisCurve");
  const std::string& bt = f_.type_of(basis);
  const bool sense = !(a[3].kind == StepValue::Kind::kEnum && a[3].text == "F");
  const bool prefer_cartesian = a[4].kind == StepValue::Kind::kEnum && a[4].text == "CARTESIAN";
  auto trim = [&](const StepValue& list, double& param, Vector2d& point, bool& has_param, bool& has_point) {
    has_param = has_point = false;
    if (!list.is_list()) return;
    for (const auto& it : list.items) {
      if (it.kind == StepValue::Kind::kTyped && it.text == "IFCPARAMETERVALUE") {
        param = it.number();
        has_param = std::isfinite(param);
      } else if (it.is_ref() && f_.contains(it.ref) && f_.type_of(it.ref) == "IFCCARTESIANPOINT") {
        point = point3(it.ref).head<2>();
        has_point = true;
      }
    }
  };
  double t1 = 0, t2 = 0;
  Vector2d q1 = Vector2d::Zero(), q2 = Vector2d::Zero();
  bool hp1, hq1, hp2, hq2;
  trim(a[1], t1, q1, hp1, hq1);
  trim(a[2], t2, q2, hp2, hq2);
  if (bt == "IFCCIRCLE" || bt == "IFCELLIPSE") {
    const Args c = args_of(basis, 2);
    const Affine P = axis_placement(c[0], basis);
    const double r1 = num(c[1], basis, "radius");
    const double r2 = bt == "IFCELLIPSE" && c.size() >= 3 ? num(c[2], basis, "SemiAxis2") : r1;
    const Affine Pinv = P.inverse();
    auto angle_of = [&](bool has_param, double param, bool has_point, const Vector2d& q) {
      if (has_point && (prefer_cartesian || !has_param)) {
        const Vector3d l = Pinv * Vector3d(q.x(), q.y(), 0.0);
        return std::atan2(l.y() / r2, l.x() / r1);
      }
      if (!has_param) fail(id, "trim without parameter or point");
      return param * units_.angle_to_rad;
    };
    const double a1 = angle_of(hp1, t1, hq1, q1);
    double a2 = angle_of(hp2, t2, hq2, q2);
    if (sense) {
      while (a2 <= a1 + 1e-12) a2 += 2 * kPi;
    } else {
      while (a2 >= a1 - 1e-12) a2 -= 2 * kPi;
    }
    const int n = arc_segments(a2 - a1);
    for (int k = 0; k <= n; ++k) {
      const double ang = a1 + (a2 - a1) * k / n;
      push_unique(out, (P * Vector3d(r1 * std::cos(ang), r2 * std::sin(ang), 0.0)).head<2>());
    }
  } else if (bt == "IFCLINE") {
    const Args l = args_of(basis, 2);
    const Vector2d p0 = point3(ref(l[0], basis, "Pnt")).head<2>();
    const Args vec = args_of(ref(l[1], basis, "Dir"), 2);
    const Vector2d d = direction(ref(vec[0], basis, "Orientation")).head<2>() * num(vec[1], basis, "Magnitude");
    const Vector2d e1 = hq1 && (prefer_cartesian || !hp1) ? q1 : p0 + d * t1;
    const Vector2d e2 = hq2 && (prefer_cartesian || !hp2) ? q2 : p0 + d * t2;
    push_unique(out, sense ? e1 : e2);
    push_unique(out, sense ? e2 : e1);
  } else {
    Loop2 whole;
    curve(basis, whole, depth + 1);
    if (!sense) std::reverse(whole.begin(), whole.end());
    for (const auto& p : whole) push_unique(out, p);
  }
}

void Builder::close_loop(Loop2& l) {
  while (l.size() > 1 && (l.front() - l.back()).squaredNorm() < 1e-24) l.pop_back();
}

Profile Builder::profile(std::uint32_t id, int depth) {
  check_depth(id, depth);
  const std::string& t = f_.type_of(id);
  Profile pr;
  Affine P = Affine::Identity();
  if (t == "IFCRECTANGLEPROFILEDEF" || t == "IFCRECTANGLEHOLLOWPROFILEDEF" || t == "IFCROUNDEDRECTANGLEPROFILEDEF") {
    const Args a = args_of(id, 5);
    P = axis_placement(a[2], id);
    const double hx = 0.5 * num(a[3], id, "XDim"), hy = 0.5 * num(a[4], id, "YDim");
    if (!(hx > 0 && hy > 0)) fail(id, "non-positive dimensions");
    pr.loops.push_back({{-hx, -hy}, {hx, -hy}, {hx, hy}, {-hx, hy}});
    if (t == "IFCRECTANGLEHOLLOWPROFILEDEF" && a.size() >= 6) {
      const double w = num(a[5], id, "WallThickness");
      if (w > 0 && w < hx && w < hy) {
        pr.loops.push_back({{-hx + w, -hy + w}, {-hx + w, hy - w}, {hx - w, hy - w}, {hx - w, -hy + w}});
      }
    }
  } else if (t == "IFCCIRCLEPROFILEDEF" || t == "IFCCIRCLEHOLLOWPROFILEDEF") {
    const Args a = args_of(id, 4);
    P = axis_placement(a[2], id);
    const double r = num(a[3], id, "Radius");
    if (!(r > 0)) fail(id, "non-positive radius");
    Loop2 l;
    arc_points(Vector2d::Zero(), r, 0, 2 * kPi, l);
    close_loop(l);
    pr.loops.push_back(l);
    if (t == "IFCCIRCLEHOLLOWPROFILEDEF" && a.size() >= 5) {
      const double w = num(a[4], id, "WallThickness");
      if (w > 0 && w < r) {
        Loop2 h;
        arc_points(Vector2d::Zero(), r - w, 0, 2 * kPi, h);
        close_loop(h);
        pr.loops.push_back(h);
      }
    }
  } else if (t == "IFCARBITRARYCLOSEDPROFILEDEF" || t == "IFCARBITRARYPROFILEDEFWITHVOIDS") {
    const Args a = args_of(id, 3);
    Loop2 outer;
    curve(ref(a[2], id, "OuterCurve"), outer, depth + 1);
    close_loop(outer);
    if (outer.size() < 3) fail(id, "outer curve has fewer than 3 points");
    pr.loops.push_back(outer);
    if (t == "IFCARBITRARYPROFILEDEFWITHVOIDS" && a.size() >= 4 && a[3].is_list()) {
      for (const auto& c : a[3].items) {
        Loop2 h;
        curve(ref(c, id, "InnerCurve"), h, depth + 1);
        close_loop(h);
        if (h.size() >= 3) pr.loops.push_back(h);
      }
    }
  } else if (t == "IFCARBITRARYOPENPROFILEDEF") {
    const Args a = args_of(id, 3);
    Loop2 l;
    curve(ref(a[2], id, "Curve"), l, depth + 1);
    pr.loops.push_back(l);
    pr.closed = false;
  } else if (t == "IFCDERIVEDPROFILEDEF") {
    const Args a = args_of(id, 4);
    pr = profile(ref(a[2], id, "ParentProfile"), depth + 1);
    P = transformation_operator(ref(a[3], id, "Operator"));
  } else {
    unsupported(id);
    fail(id, "unsupported profile type");
  }
  if (!P.matrix().isIdentity(0.0)) {
    for (auto& l : pr.loops) {
      for (auto& p : l) p = (P * Vector3d(p.x(), p.y(), 0.0)).head<2>();
    }
  }
  return pr;
}

}  // namespace plumb::bim::mesh_detail
