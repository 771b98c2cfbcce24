// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/bim/mesh.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <unordered_map>
#include <unordered_set>

#include "plumb/bim/polygon.hpp"
#include "plumb/core/error.hpp"

namespace plumb::bim {

void BimMesh::bounds(Vector3d& lo, Vector3d& hi) const {
  lo = Vector3d::Constant(std::numeric_limits<double>::infinity());
  hi = -lo;
  for (const auto& v : vertices) {
    lo = lo.cwiseMin(v);
    hi = hi.cwiseMax(v);
  }
}

int BimMesh::find_element(std::uint32_t express_id) const {
  for (std::size_t i = 0; i < elements.size(); ++i) {
    if (elements[i].express_id == express_id) return static_cast<int>(i);
  }
  return -1;
}

namespace {

using Affine = Eigen::Transform<double, 3, Eigen::Affine>;
using Loop2 = std::vector<Vector2d>;
using Tri = std::array<std::uint32_t, 3>;
using Args = std::vector<StepValue>;
constexpr double kInf = std::numeric_limits<double>::infinity();

struct Soup {
  std::vector<Vector3d> v;
  std::vector<Tri> t;
  void append(const Soup& o, const Affine& T) {
    const auto base = static_cast<std::uint32_t>(v.size());
    for (const auto& p : o.v) v.push_back(T * p);
    const bool flip = T.linear().determinant() < 0.0;
    for (const auto& tri : o.t) {
      if (flip) {
        t.push_back({base + tri[0], base + tri[2], base + tri[1]});
      } else {
        t.push_back({base + tri[0], base + tri[1], base + tri[2]});
      }
    }
  }
};

struct Profile {
  std::vector<Loop2> loops;  // [0] outer, rest holes
  bool closed = true;
};

/// A region to remove: optional half-space ∩ optional (possibly unbounded) prism, in a local frame.
struct Volume {
  Affine to_local = Affine::Identity();
  bool has_hs = false;
  Vector3d hs_n = Vector3d::UnitZ();  // local; inside iff hs_n . p + hs_d < 0
  double hs_d = 0.0;
  bool has_prism = false;
  std::vector<Loop2> loops;
  Vector3d dir = Vector3d::UnitZ();  // local extrusion direction, dir.z > 0
  double z_lo = -kInf, z_hi = kInf;
  double margin = 0.0;  // > 0: points this close outside the prism count as inside (openings)

  bool near_boundary(const Vector2d& q, double m) const {
    for (const auto& l : loops) {
      for (std::size_t i = 0; i < l.size(); ++i) {
        const Vector2d& a = l[i];
        const Vector2d& b = l[(i + 1) % l.size()];
        const Vector2d ab = b - a;
        const double len_sq = ab.squaredNorm();
        const double t = len_sq > 0 ? std::clamp((q - a).dot(ab) / len_sq, 0.0, 1.0) : 0.0;
        if ((a + t * ab - q).squaredNorm() < m * m) return true;
      }
    }
    return false;
  }

  /// Re-express for use in an outer frame where item coordinates map by T_outer_item.
  void apply(const Affine& T_outer_item) { to_local = to_local * T_outer_item.inverse(); }

  bool inside(const Vector3d& x, double eps) const {
    const Vector3d p = to_local * x;
    if (has_hs && !(hs_n.dot(p) + hs_d < -eps)) return false;
    if (has_prism) {
      const double m = margin > 0 ? margin : -eps;
      if (!(p.z() > z_lo - m && p.z() < z_hi + m)) return false;
      const double s = p.z() / dir.z();
      const Vector2d q(p.x() - dir.x() * s, p.y() - dir.y() * s);
      if (!point_in_loops(q, loops) && !(margin > 0 && near_boundary(q, margin))) return false;
    }
    return true;
  }

  /// Splitting planes in the outer frame, as (n, d) with n normalised and the volume on the
  /// negative side; `w` of the second vector is 1 when the positive side is entirely outside the
  /// volume (half-space, caps, edges of a convex boundary).
  std::vector<std::pair<Eigen::Vector4d, bool>> planes() const {
    std::vector<std::pair<Eigen::Vector4d, bool>> local;
    if (has_hs) local.push_back({Eigen::Vector4d(hs_n.x(), hs_n.y(), hs_n.z(), hs_d), true});
    if (has_prism) {
      if (std::isfinite(z_lo)) local.push_back({Eigen::Vector4d(0, 0, -1, z_lo), true});
      if (std::isfinite(z_hi)) local.push_back({Eigen::Vector4d(0, 0, 1, -z_hi), true});
      bool convex = loops.size() == 1;
      double orient = 1.0;
      if (convex) {
        const auto& l = loops[0];
        orient = signed_area(l) >= 0 ? 1.0 : -1.0;
        for (std::size_t i = 0; i < l.size() && convex; ++i) {
          const Vector2d e0 = l[(i + 1) % l.size()] - l[i];
          const Vector2d e1 = l[(i + 2) % l.size()] - l[(i + 1) % l.size()];
          convex = orient * (e0.x() * e1.y() - e0.y() * e1.x()) >= -1e-12 * e0.norm() * e1.norm();
        }
      }
      for (const auto& loop : loops) {
        for (std::size_t i = 0; i < loop.size(); ++i) {
          const Vector3d a(loop[i].x(), loop[i].y(), 0.0);
          const Vector3d b(loop[(i + 1) % loop.size()].x(), loop[(i + 1) % loop.size()].y(), 0.0);
          const Vector3d n = orient * (b - a).cross(dir);
          if (n.squaredNorm() == 0.0) continue;
          local.push_back({Eigen::Vector4d(n.x(), n.y(), n.z(), -n.dot(a)), convex});
        }
      }
    }
    const Eigen::Matrix3d A = to_local.linear();
    const Vector3d t = to_local.translation();
    std::vector<std::pair<Eigen::Vector4d, bool>> out;
    out.reserve(local.size());
    for (const auto& [pl, exclusive] : local) {
      const Vector3d nl = pl.head<3>();
      Vector3d nw = A.transpose() * nl;
      double dw = nl.dot(t) + pl[3];
      const double norm = nw.norm();
      if (!(norm > 0.0) || !std::isfinite(norm)) continue;
      nw /= norm;
      dw /= norm;
      out.push_back({Eigen::Vector4d(nw.x(), nw.y(), nw.z(), dw), exclusive});
    }
    return out;
  }

  /// Bounds in the outer frame when the prism is bounded.
  bool bounds(Vector3d& lo, Vector3d& hi) const {
    if (!has_prism || !std::isfinite(z_lo) || !std::isfinite(z_hi) || loops.empty()) return false;
    Vector2d plo = Vector2d::Constant(kInf), phi = -plo;
    for (const auto& p : loops[0]) {
      plo = plo.cwiseMin(p);
      phi = phi.cwiseMax(p);
    }
    const Affine from_local = to_local.inverse();
    lo = Vector3d::Constant(kInf);
    hi = -lo;
    for (int k = 0; k < 8; ++k) {
      const double z = (k & 4) ? z_hi : z_lo;
      const double s = z / dir.z();
      const Vector3d p((k & 1) ? phi.x() : plo.x(), (k & 2) ? phi.y() : plo.y(), 0.0);
      const Vector3d w = from_local * (p + dir * s);
      lo = lo.cwiseMin(w);
      hi = hi.cwiseMax(w);
    }
    return true;
  }
};

/// Remove the parts of the triangles inside `vol` (triangles are split along the volume's planes).
void subtract_volume(Soup& s, const Volume& vol, double eps) {
  Vector3d blo, bhi;
  const bool bounded = vol.bounds(blo, bhi);
  const auto planes = vol.planes();
  Soup out;
  out.v = s.v;
  out.t.reserve(s.t.size());
  std::vector<std::vector<Vector3d>> active, next, done;
  std::vector<double> d;
  for (const Tri& tri : s.t) {
    const Vector3d& a = s.v[tri[0]];
    const Vector3d& b = s.v[tri[1]];
    const Vector3d& c = s.v[tri[2]];
    if (bounded) {
      const Vector3d lo = a.cwiseMin(b).cwiseMin(c);
      const Vector3d hi = a.cwiseMax(b).cwiseMax(c);
      const double tol = eps + std::max(vol.margin, 0.0);
      if ((lo.array() > bhi.array() + tol).any() || (hi.array() < blo.array() - tol).any()) {
        out.t.push_back(tri);
        continue;
      }
    }
    active.assign(1, {a, b, c});
    done.clear();
    for (const auto& [pl, exclusive] : planes) {
      next.clear();
      for (auto& poly : active) {
        bool pos = false, neg = false;
        d.resize(poly.size());
        for (std::size_t i = 0; i < poly.size(); ++i) {
          d[i] = pl.head<3>().dot(poly[i]) + pl[3];
          pos |= d[i] > eps;
          neg |= d[i] < -eps;
        }
        if (!neg) {  // outside this plane (or on it: decided by the centroid test)
          (exclusive && pos ? done : next).push_back(std::move(poly));
          continue;
        }
        if (!pos) {
          next.push_back(std::move(poly));
          continue;
        }
        std::vector<Vector3d> P, N;
        for (std::size_t i = 0; i < poly.size(); ++i) {
          const std::size_t j = (i + 1) % poly.size();
          const double di = d[i], dj = d[j];
          if (di >= -eps) P.push_back(poly[i]);
          if (di <= eps) N.push_back(poly[i]);
          if ((di > eps && dj < -eps) || (di < -eps && dj > eps)) {
            const Vector3d x = poly[i] + (poly[j] - poly[i]) * (di / (di - dj));
            P.push_back(x);
            N.push_back(x);
          }
        }
        if (P.size() >= 3) (exclusive ? done : next).push_back(std::move(P));
        if (N.size() >= 3) next.push_back(std::move(N));
      }
      active.swap(next);
    }
    // A piece is removed when the material just behind it (against its outward normal) is inside
    // the volume: this also drops faces that lie on the volume's boundary with their material gone.
    Vector3d n = (b - a).cross(c - a);
    const double nn = n.norm();
    n = nn > 0 ? Vector3d(n / nn) : Vector3d::Zero();
    for (auto& poly : active) {
      Vector3d centroid = Vector3d::Zero();
      for (const auto& p : poly) centroid += p;
      centroid /= static_cast<double>(poly.size());
      if (!vol.inside(centroid - 10.0 * eps * n, eps)) done.push_back(std::move(poly));
    }
    if (done.size() == 1 && done[0].size() == 3 && done[0][0] == a && done[0][1] == b && done[0][2] == c) {
      out.t.push_back(tri);
      continue;
    }
    for (const auto& poly : done) {
      const auto base = static_cast<std::uint32_t>(out.v.size());
      for (const auto& p : poly) out.v.push_back(p);
      for (std::uint32_t k = 1; k + 1 < poly.size(); ++k) out.t.push_back({base, base + k, base + k + 1});
    }
  }
  s = std::move(out);
}

/// Generalised winding number of a triangle soup around p (Jacobson et al. 2013: the solid angles
/// of the triangles, Van Oosterom and Strackee 1983): about +-1 inside a closed surface, 0 outside.
double winding_number(const Soup& s, const Vector3d& p) {
  double sum = 0.0;
  for (const Tri& t : s.t) {
    const Vector3d a = s.v[t[0]] - p, b = s.v[t[1]] - p, c = s.v[t[2]] - p;
    const double la = a.norm(), lb = b.norm(), lc = c.norm();
    const double num = a.dot(b.cross(c));
    const double den = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
    sum += 2.0 * std::atan2(num, den);
  }
  return sum / (4.0 * kPi);
}

/// Split convex polygons by a plane (n, d): pieces on either side, `eps` thick plane.
void split_by_plane(std::vector<std::vector<Vector3d>>& polys, const Vector3d& n, double d, double eps) {
  std::vector<std::vector<Vector3d>> out;
  out.reserve(polys.size());
  std::vector<double> dist;
  for (auto& poly : polys) {
    bool pos = false, neg = false;
    dist.resize(poly.size());
    for (std::size_t i = 0; i < poly.size(); ++i) {
      dist[i] = n.dot(poly[i]) + d;
      pos |= dist[i] > eps;
      neg |= dist[i] < -eps;
    }
    if (!pos || !neg) {
      out.push_back(std::move(poly));
      continue;
    }
    std::vector<Vector3d> P, N;
    for (std::size_t i = 0; i < poly.size(); ++i) {
      const std::size_t j = (i + 1) % poly.size();
      const double di = dist[i], dj = dist[j];
      if (di >= -eps) P.push_back(poly[i]);
      if (di <= eps) N.push_back(poly[i]);
      if ((di > eps && dj < -eps) || (di < -eps && dj > eps)) {
        const Vector3d x = poly[i] + (poly[j] - poly[i]) * (di / (di - dj));
        P.push_back(x);
        N.push_back(x);
      }
    }
    if (P.size() >= 3) out.push_back(std::move(P));
    if (N.size() >= 3) out.push_back(std::move(N));
  }
  polys.swap(out);
}

/// The faces a subtraction of `vol` from the solid bounded by `s` creates: the parts of the volume's
/// boundary inside the solid (the reveals of a door or window opening, the back of a niche, the cut
/// face of a clipping half-space), oriented towards the removed volume. Add them to the result of
/// subtract_volume() to keep the element closed (boolean difference: boundary = (boundary of A
/// outside B) + (boundary of B inside A, reversed)).
Soup reveal_faces(const Soup& s, const Volume& vol, double eps) {
  Soup out;
  if (s.t.empty() || (!vol.has_hs && !vol.has_prism)) return out;
  // Everything happens within the solid's bounds; unbounded parts of the volume are cut there.
  Vector3d alo = Vector3d::Constant(kInf), ahi = -alo;
  for (const Tri& t : s.t) {
    for (std::uint32_t k : t) {
      alo = alo.cwiseMin(s.v[k]);
      ahi = ahi.cwiseMax(s.v[k]);
    }
  }
  const double margin = 1.0 + (ahi - alo).norm();
  alo -= Vector3d::Constant(margin);
  ahi += Vector3d::Constant(margin);
  const Affine from_local = vol.to_local.inverse();
  const bool mirrored = from_local.linear().determinant() < 0.0;
  // Candidate faces: each with its normal pointing into the volume.
  std::vector<std::vector<Vector3d>> faces;
  auto add_face = [&](std::vector<Vector3d> f, bool flip) {
    if (flip) std::reverse(f.begin(), f.end());
    faces.push_back(std::move(f));
  };
  if (vol.has_hs) {
    // A square on the plane covering the solid: material (inside) is n.x + d < 0 in the outer frame.
    const auto pl = vol.planes().front().first;  // the half-space comes first
    const Vector3d n = pl.head<3>();
    const Vector3d c0 = 0.5 * (alo + ahi);
    const Vector3d c = c0 - (n.dot(c0) + pl[3]) * n;
    int k = 0;
    n.cwiseAbs().minCoeff(&k);
    const Vector3d u = n.cross(Vector3d::Unit(k)).normalized(), w = n.cross(u);
    const double r = (ahi - alo).norm();
    // (u, w, n) is right-handed; this order is clockwise in (u, w), so the face looks along -n,
    // into the volume.
    add_face({c + r * (u + w), c + r * (u - w), c + r * (-u - w), c + r * (-u + w)}, false);
  }
  if (vol.has_prism) {
    std::vector<Loop2> loops = vol.loops;
    for (std::size_t k = 0; k < loops.size(); ++k) {  // outer counter-clockwise, holes clockwise
      if ((k == 0) != (signed_area(loops[k]) > 0)) std::reverse(loops[k].begin(), loops[k].end());
    }
    // Local z range of the solid's bounds.
    double zmin = kInf, zmax = -kInf;
    for (int corner = 0; corner < 8; ++corner) {
      const Vector3d p((corner & 1) ? ahi.x() : alo.x(), (corner & 2) ? ahi.y() : alo.y(), (corner & 4) ? ahi.z() : alo.z());
      const double z = (vol.to_local * p).z();
      zmin = std::min(zmin, z);
      zmax = std::max(zmax, z);
    }
    const double z_lo = std::max(vol.z_lo, zmin), z_hi = std::min(vol.z_hi, zmax);
    if (z_lo < z_hi) {
      auto at = [&](const Vector2d& q, double z) {
        return Vector3d(from_local * (Vector3d(q.x(), q.y(), 0.0) + vol.dir * (z / vol.dir.z())));
      };
      for (const auto& l : loops) {
        for (std::size_t i = 0; i < l.size(); ++i) {
          const Vector2d& a = l[i];
          const Vector2d& b = l[(i + 1) % l.size()];
          if ((b - a).squaredNorm() == 0.0) continue;
          // Outward order a_lo b_lo b_hi a_hi, reversed.
          add_face({at(a, z_lo), at(a, z_hi), at(b, z_hi), at(b, z_lo)}, mirrored);
        }
      }
      std::vector<Vector2d> flat;
      for (const auto& l : loops) flat.insert(flat.end(), l.begin(), l.end());
      const auto caps = triangulate_polygon(loops);  // counter-clockwise: +z
      for (const Tri& t : caps) {
        if (std::isfinite(vol.z_lo) && z_lo == vol.z_lo) {  // bottom, faces +z
          add_face({at(flat[t[0]], z_lo), at(flat[t[1]], z_lo), at(flat[t[2]], z_lo)}, mirrored);
        }
        if (std::isfinite(vol.z_hi) && z_hi == vol.z_hi) {  // top, faces -z
          add_face({at(flat[t[0]], z_hi), at(flat[t[2]], z_hi), at(flat[t[1]], z_hi)}, mirrored);
        }
      }
    }
  }
  Vector3d blo = alo, bhi = ahi;
  Vector3d vlo, vhi;
  if (vol.bounds(vlo, vhi)) {
    blo = blo.cwiseMax(vlo);
    bhi = bhi.cwiseMin(vhi);
  }
  // Split them along the planes of the solid's faces near the volume: every piece then lies
  // entirely inside or entirely outside the solid.
  const double tol = eps + std::max(vol.margin, 0.0);
  std::vector<Eigen::Vector4d> planes;
  for (const Tri& t : s.t) {
    const Vector3d& a = s.v[t[0]];
    const Vector3d& b = s.v[t[1]];
    const Vector3d& c = s.v[t[2]];
    const Vector3d lo = a.cwiseMin(b).cwiseMin(c), hi = a.cwiseMax(b).cwiseMax(c);
    if ((lo.array() > bhi.array() + tol).any() || (hi.array() < blo.array() - tol).any()) continue;
    Vector3d n = (b - a).cross(c - a);
    const double nn = n.norm();
    if (!(nn > 0.0)) continue;
    n /= nn;
    double d = -n.dot(a);
    // One sign per plane, so both orientations of a face deduplicate.
    int k = 0;
    n.cwiseAbs().maxCoeff(&k);
    if (n[k] < 0) {
      n = -n;
      d = -d;
    }
    bool seen = false;
    for (const auto& p : planes) {
      if ((p.head<3>() - n).squaredNorm() < 1e-18 && std::abs(p[3] - d) < eps) {
        seen = true;
        break;
      }
    }
    if (!seen) planes.emplace_back(n.x(), n.y(), n.z(), d);
  }
  const auto vol_planes = vol.planes();
  // A piece is a face of the difference when the material just outside the volume, next to it,
  // belongs to the solid.
  const double step = 1000.0 * eps;
  for (auto& f : faces) {
    Vector3d n = (f[1] - f[0]).cross(f[2] - f[0]);
    const double nn = n.norm();
    if (!(nn > 0.0)) continue;
    n /= nn;  // into the volume
    std::vector<std::vector<Vector3d>> pieces(1, std::move(f));
    for (const auto& p : planes) split_by_plane(pieces, p.head<3>(), p[3], eps);
    for (const auto& p : vol_planes) split_by_plane(pieces, p.first.head<3>(), p.first[3], eps);
    for (const auto& piece : pieces) {
      Vector3d centroid = Vector3d::Zero();
      for (const auto& q : piece) centroid += q;
      centroid /= static_cast<double>(piece.size());
      // On the volume's boundary (a candidate face may run outside the volume: the half-space
      // plane beyond a bounding polygon, a prism side beyond the half-space) ...
      if (!vol.inside(centroid + step * n, eps) || vol.inside(centroid - step * n, eps)) continue;
      // ... and against the solid's material.
      if (std::abs(winding_number(s, centroid - step * n)) < 0.5) continue;
      const auto base = static_cast<std::uint32_t>(out.v.size());
      out.v.insert(out.v.end(), piece.begin(), piece.end());
      for (std::uint32_t k = 1; k + 1 < piece.size(); ++k) out.t.push_back({base, base + k, base + k + 1});
    }
  }
  return out;
}

class Builder {
 public:
  Builder(const IfcModel& model, const BimMeshSettings& settings)
      : f_(model.step), units_(model.units), settings_(settings) {
    eps_ = 1e-7 / units_.length_to_m;  // 0.1 um in file units
  }

  BimMesh run();

 private:
  const StepFile& f_;
  const IfcUnits& units_;
  const BimMeshSettings& settings_;
  double eps_ = 1e-9;
  BimMesh mesh_;
  std::unordered_map<std::uint32_t, Affine> placement_cache_;
  std::map<std::string, std::pair<std::size_t, std::uint32_t>> unsupported_;  // type -> (count, first id)

  // ---- helpers -------------------------------------------------------------------------------
  [[noreturn]] void fail(std::uint32_t id, const std::string& msg) const {
    PLUMB_THROW(f_.where(id) << ": " << f_.type_of(id) << " #" << id << ": " << msg);
  }
  void check_depth(std::uint32_t id, int depth) const {
    if (depth > settings_.max_depth) fail(id, "reference chain deeper than " + std::to_string(settings_.max_depth) + " (cycle?)");
  }
  Args args_of(std::uint32_t id, std::size_t min_args) const {
    if (!f_.contains(id)) PLUMB_THROW(f_.name() << ": dangling reference #" << id);
    Args a = f_.args(id);
    if (a.size() < min_args) fail(id, "expects at least " + std::to_string(min_args) + " arguments");
    return a;
  }
  std::uint32_t ref(const StepValue& v, std::uint32_t owner, const char* what) const {
    if (!v.is_ref()) fail(owner, std::string(what) + " is not a reference");
    if (!f_.contains(v.ref)) fail(owner, std::string(what) + " refers to missing #" + std::to_string(v.ref));
    return v.ref;
  }
  double num(const StepValue& v, std::uint32_t owner, const char* what) const {
    const double x = v.number();
    if (!std::isfinite(x) || std::abs(x) > 1e12) fail(owner, std::string(what) + " is not a finite number");
    return x;
  }
  void unsupported(std::uint32_t id) {
    auto& e = unsupported_[f_.type_of(id)];
    if (e.first++ == 0) e.second = id;
  }

  Vector3d point3(std::uint32_t id) const {
    const Args a = args_of(id, 1);
    if (!a[0].is_list() || a[0].items.empty() || a[0].items.size() > 3) fail(id, "expects a coordinate list");
    Vector3d p = Vector3d::Zero();
    for (std::size_t i = 0; i < a[0].items.size(); ++i) p[static_cast<int>(i)] = num(a[0].items[i], id, "coordinate");
    return p;
  }
  Vector3d direction(std::uint32_t id) const {
    Vector3d d = point3(id);  // IfcDirection has the same layout
    const double n = d.norm();
    if (!(n > 0.0)) fail(id, "zero direction");
    return d / n;
  }
  Vector3d opt_dir(const StepValue& v, std::uint32_t owner, const Vector3d& dflt) const {
    if (v.is_null()) return dflt;
    return direction(ref(v, owner, "direction"));
  }

  static Eigen::Matrix3d frame_from(const Vector3d& z_in, const Vector3d& x_in) {
    const Vector3d z = z_in.normalized();
    Vector3d x = x_in - x_in.dot(z) * z;
    if (x.norm() < 1e-12) {
      x = std::abs(z.x()) < 0.9 ? Vector3d::UnitX() : Vector3d::UnitY();
      x = (x - x.dot(z) * z);
    }
    x.normalize();
    Eigen::Matrix3d R;
    R.col(0) = x;
    R.col(1) = z.cross(x);
    R.col(2) = z;
    return R;
  }

  /// IfcAxis2Placement3D / 2D (or $ -> identity).
  Affine axis_placement(const StepValue& v, std::uint32_t owner) const {
    if (v.is_null()) return Affine::Identity();
    const std::uint32_t id = ref(v, owner, "placement");
    const std::string& t = f_.type_of(id);
    Affine T = Affine::Identity();
    if (t == "IFCAXIS2PLACEMENT3D") {
      const Args a = args_of(id, 3);
      const Vector3d o = point3(ref(a[0], id, "Location"));
      const Vector3d z = opt_dir(a[1], id, Vector3d::UnitZ());
      const Vector3d x = opt_dir(a[2], id, Vector3d::UnitX());
      T.linear() = frame_from(z, x);
      T.translation() = o;
    } else if (t == "IFCAXIS2PLACEMENT2D") {
      const Args a = args_of(id, 2);
      const Vector3d o = point3(ref(a[0], id, "Location"));
      Vector3d x = opt_dir(a[1], id, Vector3d::UnitX());
      x.z() = 0.0;
      T.linear() = frame_from(Vector3d::UnitZ(), x);
      T.translation() = Vector3d(o.x(), o.y(), 0.0);
    } else {
      fail(id, "unsupported placement type");
    }
    return T;
  }

  Affine local_placement(std::uint32_t id, int depth) {
    check_depth(id, depth);
    auto it = placement_cache_.find(id);
    if (it != placement_cache_.end()) return it->second;
    const std::string& t = f_.type_of(id);
    Affine T = Affine::Identity();
    if (t == "IFCLOCALPLACEMENT") {
      const Args a = args_of(id, 2);
      Affine parent = Affine::Identity();
      if (!a[0].is_null()) parent = local_placement(ref(a[0], id, "PlacementRelTo"), depth + 1);
      T = parent * axis_placement(a[1], id);
    } else {
      fail(id, "unsupported object placement");
    }
    placement_cache_.emplace(id, T);
    return T;
  }

  /// IfcCartesianTransformationOperator2D/3D (+NonUniform).
  Affine transformation_operator(std::uint32_t id) const {
    const std::string& t = f_.type_of(id);
    const bool is3d = t.find("3D") != std::string::npos;
    const Args a = args_of(id, 4);
    const Vector3d origin = point3(ref(a[2], id, "LocalOrigin"));
    const double s1 = a[3].is_null() ? 1.0 : num(a[3], id, "Scale");
    double s2 = s1, s3 = s1;
    Vector3d z = Vector3d::UnitZ();
    if (is3d && a.size() >= 5 && !a[4].is_null()) z = direction(ref(a[4], id, "Axis3"));
    if (t.find("NONUNIFORM") != std::string::npos) {
      const std::size_t k = is3d ? 5 : 4;
      if (a.size() > k && !a[k].is_null()) s2 = num(a[k], id, "Scale2");
      if (is3d && a.size() > k + 1 && !a[k + 1].is_null()) s3 = num(a[k + 1], id, "Scale3");
    }
    Vector3d x = a[0].is_null() ? Vector3d::UnitX() : direction(ref(a[0], id, "Axis1"));
    Eigen::Matrix3d R = frame_from(z, x);
    if (!a[1].is_null()) {  // Axis2: projected orthogonal to z and x
      Vector3d y = direction(ref(a[1], id, "Axis2"));
      y = y - y.dot(R.col(2)) * R.col(2) - y.dot(R.col(0)) * R.col(0);
      if (y.norm() > 1e-12 && y.normalized().dot(R.col(1)) < 0.0) R.col(1) = -R.col(1);
    }
    Affine T = Affine::Identity();
    T.linear() = R * Vector3d(s1, s2, s3).asDiagonal();
    T.translation() = is3d ? origin : Vector3d(origin.x(), origin.y(), 0.0);
    return T;
  }

  // ---- curves and profiles ---------------------------------------------------------------------
  int arc_segments(double sweep) const {
    const double per = 2.0 * kPi / std::max(3, settings_.circle_segments);
    return std::max(2, static_cast<int>(std::ceil(std::abs(sweep) / per - 1e-9)));
  }

  static void push_unique(Loop2& out, const Vector2d& p) {
    if (out.empty() || (out.back() - p).squaredNorm() > 1e-24) out.push_back(p);
  }

  void arc_points(const Vector2d& c, double r, double a0, double a1, Loop2& out) const {
    const int n = arc_segments(a1 - a0);
    for (int k = 0; k <= n; ++k) {
      const double a = a0 + (a1 - a0) * k / n;
      push_unique(out, c + r * Vector2d(std::cos(a), std::sin(a)));
    }
  }

  void curve(std::uint32_t id, Loop2& out, int depth) {
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
          if (seg.kind != StepValue::Kind::kTyped || seg.items.empty() || !seg.items[0].is_list()) fail(id, "bad segment");
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

  void three_point_arc(const Vector2d& p1, const Vector2d& p2, const Vector2d& p3, Loop2& out) const {
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

  void trimmed_curve(std::uint32_t id, Loop2& out, int depth) {
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

  static void close_loop(Loop2& l) {
    while (l.size() > 1 && (l.front() - l.back()).squaredNorm() < 1e-24) l.pop_back();
  }

  Profile profile(std::uint32_t id, int depth) {
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
        if (w > 0 && w < hx && w < hy) pr.loops.push_back({{-hx + w, -hy + w}, {-hx + w, hy - w}, {hx - w, hy - w}, {hx - w, -hy + w}});
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

  // ---- solids and surfaces -------------------------------------------------------------------
  static void add_polygon3(Soup& s, const std::vector<std::vector<Vector3d>>& loops3) {
    if (loops3.empty() || loops3[0].size() < 3) return;
    const auto& o = loops3[0];
    if (loops3.size() == 1 && o.size() == 3) {
      const auto b = static_cast<std::uint32_t>(s.v.size());
      s.v.insert(s.v.end(), o.begin(), o.end());
      s.t.push_back({b, b + 1, b + 2});
      return;
    }
    Vector3d n = Vector3d::Zero();  // Newell normal of the outer loop
    for (std::size_t i = 0; i < o.size(); ++i) {
      const Vector3d& a = o[i];
      const Vector3d& b = o[(i + 1) % o.size()];
      n += Vector3d((a.y() - b.y()) * (a.z() + b.z()), (a.z() - b.z()) * (a.x() + b.x()), (a.x() - b.x()) * (a.y() + b.y()));
    }
    if (!(n.norm() > 0.0)) return;
    n.normalize();
    const Eigen::Matrix3d R = frame_from(n, std::abs(n.x()) < 0.9 ? Vector3d::UnitX() : Vector3d::UnitY());
    std::vector<Loop2> loops2;
    loops2.reserve(loops3.size());
    const auto base = static_cast<std::uint32_t>(s.v.size());
    for (const auto& l : loops3) {
      Loop2 l2;
      l2.reserve(l.size());
      for (const auto& p : l) {
        l2.emplace_back(R.col(0).dot(p), R.col(1).dot(p));
        s.v.push_back(p);
      }
      loops2.push_back(std::move(l2));
    }
    // Triangulation is ccw in (x, y) of the frame, i.e. around +n (the outer loop's own normal).
    for (const Tri& t : triangulate_polygon(loops2)) s.t.push_back({base + t[0], base + t[1], base + t[2]});
  }

  void extrusion(std::uint32_t id, Soup& s, int depth) {
    const Args a = args_of(id, 4);
    Profile pr = profile(ref(a[0], id, "SweptArea"), depth + 1);
    const Affine P = axis_placement(a[1], id);
    Vector3d d = direction(ref(a[2], id, "ExtrudedDirection"));
    const double len = num(a[3], id, "Depth");
    if (!(len > 0)) fail(id, "non-positive extrusion depth");
    const Vector3d v = d * len;
    Soup local;
    if (!pr.closed) {
      const auto& l = pr.loops[0];
      for (std::size_t i = 0; i + 1 < l.size(); ++i) {
        const auto b = static_cast<std::uint32_t>(local.v.size());
        const Vector3d p0(l[i].x(), l[i].y(), 0), p1(l[i + 1].x(), l[i + 1].y(), 0);
        local.v.insert(local.v.end(), {p0, p1, p1 + v, p0 + v});
        local.t.push_back({b, b + 1, b + 2});
        local.t.push_back({b, b + 2, b + 3});
      }
      s.append(local, P);
      return;
    }
    // Orientation: outer ccw, holes cw (so sides face outwards for d.z > 0).
    for (std::size_t k = 0; k < pr.loops.size(); ++k) {
      const double area = signed_area(pr.loops[k]);
      if ((k == 0) != (area > 0)) std::reverse(pr.loops[k].begin(), pr.loops[k].end());
    }
    const bool flip = d.z() < 0;
    const auto caps = triangulate_polygon(pr.loops);
    std::uint32_t offset = 0;
    std::vector<std::uint32_t> loop_start;
    for (const auto& l : pr.loops) {
      loop_start.push_back(offset);
      for (const auto& p : l) local.v.emplace_back(p.x(), p.y(), 0.0);
      offset += static_cast<std::uint32_t>(l.size());
    }
    for (std::uint32_t i = 0; i < offset; ++i) local.v.push_back(local.v[i] + v);
    auto tri = [&](std::uint32_t x, std::uint32_t y, std::uint32_t z) {
      if (flip) {
        local.t.push_back({x, z, y});
      } else {
        local.t.push_back({x, y, z});
      }
    };
    for (const Tri& t : caps) {
      tri(t[0], t[2], t[1]);                            // bottom faces -z
      tri(t[0] + offset, t[1] + offset, t[2] + offset);  // top faces +z
    }
    for (std::size_t k = 0; k < pr.loops.size(); ++k) {
      const auto n = static_cast<std::uint32_t>(pr.loops[k].size());
      for (std::uint32_t i = 0; i < n; ++i) {
        const std::uint32_t i0 = loop_start[k] + i, i1 = loop_start[k] + (i + 1) % n;
        tri(i0, i1, i1 + offset);
        tri(i0, i1 + offset, i0 + offset);
      }
    }
    s.append(local, P);
  }

  void face(std::uint32_t id, Soup& s) {
    const Args a = args_of(id, 1);
    if (!a[0].is_list()) fail(id, "Bounds must be a list");
    std::vector<std::vector<Vector3d>> loops;
    int outer = -1;
    for (const auto& b : a[0].items) {
      const std::uint32_t bid = ref(b, id, "bound");
      const Args ba = args_of(bid, 2);
      const std::uint32_t lid = ref(ba[0], bid, "Bound");
      if (f_.type_of(lid) != "IFCPOLYLOOP") {
        unsupported(lid);
        continue;
      }
      const Args la = args_of(lid, 1);
      if (!la[0].is_list()) fail(lid, "Polygon must be a list");
      std::vector<Vector3d> loop;
      loop.reserve(la[0].items.size());
      for (const auto& p : la[0].items) loop.push_back(point3(ref(p, lid, "point")));
      if (ba[1].kind == StepValue::Kind::kEnum && ba[1].text == "F") std::reverse(loop.begin(), loop.end());
      if (f_.type_of(bid) == "IFCFACEOUTERBOUND" && outer < 0) outer = static_cast<int>(loops.size());
      loops.push_back(std::move(loop));
    }
    if (loops.empty()) return;
    if (outer > 0) std::swap(loops[0], loops[static_cast<std::size_t>(outer)]);
    add_polygon3(s, loops);
  }

  void face_set(std::uint32_t id, Soup& s) {  // IfcClosedShell / IfcOpenShell / IfcConnectedFaceSet
    const Args a = args_of(id, 1);
    if (!a[0].is_list()) fail(id, "CfsFaces must be a list");
    for (const auto& fv : a[0].items) face(ref(fv, id, "face"), s);
  }

  void tessellated(std::uint32_t id, Soup& s) {
    const std::string& t = f_.type_of(id);
    const Args a = args_of(id, 3);
    const std::uint32_t cid = ref(a[0], id, "Coordinates");
    const Args ca = args_of(cid, 1);
    if (!ca[0].is_list()) fail(cid, "CoordList must be a list");
    const auto base = static_cast<std::uint32_t>(s.v.size());
    const std::size_t npts = ca[0].items.size();
    for (const auto& c : ca[0].items) {
      if (!c.is_list() || c.items.size() != 3) fail(cid, "bad coordinate");
      s.v.emplace_back(num(c.items[0], cid, "x"), num(c.items[1], cid, "y"), num(c.items[2], cid, "z"));
    }
    if (t == "IFCTRIANGULATEDFACESET" || t == "IFCTRIANGULATEDIRREGULARNETWORK") {
      if (a.size() < 4 || !a[3].is_list()) fail(id, "CoordIndex must be a list");
      const StepValue* pn = a.size() >= 5 && a[4].is_list() ? &a[4] : nullptr;
      auto index = [&](const StepValue& v) -> std::uint32_t {
        double k = v.number();
        if (pn) {
          if (!(k >= 1 && k <= static_cast<double>(pn->items.size()))) fail(id, "PnIndex out of range");
          k = pn->items[static_cast<std::size_t>(k) - 1].number();
        }
        if (!(k >= 1 && k <= static_cast<double>(npts))) fail(id, "coordinate index out of range");
        return base + static_cast<std::uint32_t>(k) - 1;
      };
      for (const auto& tri : a[3].items) {
        if (!tri.is_list() || tri.items.size() != 3) fail(id, "triangle needs 3 indices");
        s.t.push_back({index(tri.items[0]), index(tri.items[1]), index(tri.items[2])});
      }
    } else {  // IFCPOLYGONALFACESET(Coordinates, Closed, Faces, PnIndex)
      if (!a[2].is_list()) fail(id, "Faces must be a list");
      const StepValue* pn = a.size() >= 4 && a[3].is_list() ? &a[3] : nullptr;
      auto pt = [&](const StepValue& v) -> Vector3d {
        double k = v.number();
        if (pn) {
          if (!(k >= 1 && k <= static_cast<double>(pn->items.size()))) fail(id, "PnIndex out of range");
          k = pn->items[static_cast<std::size_t>(k) - 1].number();
        }
        if (!(k >= 1 && k <= static_cast<double>(npts))) fail(id, "coordinate index out of range");
        return s.v[base + static_cast<std::uint32_t>(k) - 1];
      };
      for (const auto& fv : a[2].items) {
        const std::uint32_t fid = ref(fv, id, "face");
        const Args fa = args_of(fid, 1);
        std::vector<std::vector<Vector3d>> loops(1);
        if (!fa[0].is_list()) fail(fid, "CoordIndex must be a list");
        for (const auto& k : fa[0].items) loops[0].push_back(pt(k));
        if (fa.size() >= 2 && fa[1].is_list()) {
          for (const auto& inner : fa[1].items) {
            if (!inner.is_list()) continue;
            loops.emplace_back();
            for (const auto& k : inner.items) loops.back().push_back(pt(k));
          }
        }
        add_polygon3(s, loops);
      }
    }
  }

  /// A half-space or solid operand as a removal volume in item coordinates.
  Volume volume(std::uint32_t id, int depth) {
    check_depth(id, depth);
    const std::string& t = f_.type_of(id);
    Volume vol;
    if (t == "IFCHALFSPACESOLID" || t == "IFCPOLYGONALBOUNDEDHALFSPACE" || t == "IFCBOXEDHALFSPACE") {
      const Args a = args_of(id, 2);
      const std::uint32_t sid = ref(a[0], id, "BaseSurface");
      if (f_.type_of(sid) != "IFCPLANE") {
        unsupported(sid);
        fail(id, "base surface is not an IfcPlane");
      }
      const Args pa = args_of(sid, 1);
      const Affine Pp = axis_placement(pa[0], sid);
      // AgreementFlag TRUE: the plane normal points away from the half-space material.
      const bool agree = !(a[1].kind == StepValue::Kind::kEnum && a[1].text == "F");
      Vector3d n = Pp.linear().col(2);
      double d = -n.dot(Pp.translation());
      if (!agree) {
        n = -n;
        d = -d;
      }
      // Material (inside) is n.x + d < 0 in item coordinates.
      if (t == "IFCPOLYGONALBOUNDEDHALFSPACE" && a.size() >= 4) {
        const Affine Pos = axis_placement(a[2], id);
        Loop2 boundary;
        curve(ref(a[3], id, "PolygonalBoundary"), boundary, depth + 1);
        close_loop(boundary);
        if (boundary.size() < 3) fail(id, "boundary has fewer than 3 points");
        vol.to_local = Pos.inverse();
        vol.has_prism = true;
        vol.loops.push_back(boundary);
        vol.dir = Vector3d::UnitZ();
      }
      // Express the plane in the local frame: x = L^{-1} p.
      const Affine from_local = vol.to_local.inverse();
      vol.has_hs = true;
      vol.hs_n = from_local.linear().transpose() * n;
      vol.hs_d = n.dot(from_local.translation()) + d;
      const double nn = vol.hs_n.norm();
      vol.hs_n /= nn;
      vol.hs_d /= nn;
    } else if (t == "IFCEXTRUDEDAREASOLID") {
      const Args a = args_of(id, 4);
      Profile pr = profile(ref(a[0], id, "SweptArea"), depth + 1);
      if (!pr.closed) fail(id, "open profile cannot bound a volume");
      Vector3d d = direction(ref(a[2], id, "ExtrudedDirection"));
      const double len = num(a[3], id, "Depth");
      if (std::abs(d.z()) < 1e-9) fail(id, "extrusion direction parallel to the profile plane");
      vol.to_local = axis_placement(a[1], id).inverse();
      vol.has_prism = true;
      vol.loops = pr.loops;
      if (d.z() < 0) {
        vol.dir = -d;
        vol.z_lo = d.z() * len;
        vol.z_hi = 0.0;
      } else {
        vol.dir = d;
        vol.z_lo = 0.0;
        vol.z_hi = d.z() * len;
      }
    } else {
      // Any other solid: its axis-aligned box (openings are nearly always boxes).
      Soup s;
      item(id, s, depth + 1);
      if (s.v.empty()) fail(id, "operand has no geometry");
      Vector3d lo = Vector3d::Constant(kInf), hi = -lo;
      for (const auto& p : s.v) {
        lo = lo.cwiseMin(p);
        hi = hi.cwiseMax(p);
      }
      vol.has_prism = true;
      vol.loops.push_back({{lo.x(), lo.y()}, {hi.x(), lo.y()}, {hi.x(), hi.y()}, {lo.x(), hi.y()}});
      vol.z_lo = lo.z();
      vol.z_hi = hi.z();
    }
    return vol;
  }

  void boolean_result(std::uint32_t id, Soup& s, int depth) {
    const Args a = args_of(id, 3);
    const std::string op = a[0].text;
    Soup first;
    item(ref(a[1], id, "FirstOperand"), first, depth + 1);
    const std::uint32_t second = ref(a[2], id, "SecondOperand");
    if (op == "UNION") {
      item(second, first, depth + 1);
    } else if (op == "DIFFERENCE") {
      const Volume vol = volume(second, depth + 1);
      const Soup cut = reveal_faces(first, vol, eps_);
      subtract_volume(first, vol, eps_);
      first.append(cut, Affine::Identity());
    } else {
      unsupported(id);  // INTERSECTION: keep the first operand
    }
    s.append(first, Affine::Identity());
  }

  void mapped_item(std::uint32_t id, Soup& s, int depth) {
    const Args a = args_of(id, 2);
    const std::uint32_t map = ref(a[0], id, "MappingSource");
    const Args ma = args_of(map, 2);
    const Affine origin = [&]() {
      if (ma[0].is_ref() && f_.type_of(ma[0].ref).rfind("IFCCARTESIANTRANSFORMATIONOPERATOR", 0) == 0) {
        return transformation_operator(ma[0].ref);
      }
      return axis_placement(ma[0], map);
    }();
    const Affine target = transformation_operator(ref(a[1], id, "MappingTarget"));
    Soup local;
    representation_items(ref(ma[1], map, "MappedRepresentation"), local, depth + 1);
    s.append(local, target * origin);
  }

  void representation_items(std::uint32_t rep, Soup& s, int depth) {
    check_depth(rep, depth);
    const Args a = args_of(rep, 4);
    if (!a[3].is_list()) fail(rep, "Items must be a list");
    for (const auto& it : a[3].items) item(ref(it, rep, "item"), s, depth + 1);
  }

 public:
  /// Geometry of one representation item in its own coordinates, appended to s.
  void item(std::uint32_t id, Soup& s, int depth) {
    check_depth(id, depth);
    const std::string& t = f_.type_of(id);
    if (t == "IFCEXTRUDEDAREASOLID") {
      extrusion(id, s, depth);
    } else if (t == "IFCFACETEDBREP" || t == "IFCFACETEDBREPWITHVOIDS") {
      const Args a = args_of(id, 1);
      face_set(ref(a[0], id, "Outer"), s);
    } else if (t == "IFCCLOSEDSHELL" || t == "IFCOPENSHELL" || t == "IFCCONNECTEDFACESET") {
      face_set(id, s);
    } else if (t == "IFCFACEBASEDSURFACEMODEL" || t == "IFCSHELLBASEDSURFACEMODEL") {
      const Args a = args_of(id, 1);
      if (!a[0].is_list()) fail(id, "expects a list");
      for (const auto& sh : a[0].items) face_set(ref(sh, id, "shell"), s);
    } else if (t == "IFCTRIANGULATEDFACESET" || t == "IFCPOLYGONALFACESET" || t == "IFCTRIANGULATEDIRREGULARNETWORK") {
      tessellated(id, s);
    } else if (t == "IFCMAPPEDITEM") {
      mapped_item(id, s, depth);
    } else if (t == "IFCBOOLEANCLIPPINGRESULT" || t == "IFCBOOLEANRESULT") {
      boolean_result(id, s, depth);
    } else if (t == "IFCSURFACEOFLINEAREXTRUSION") {
      const Args a = args_of(id, 4);
      Profile pr = profile(ref(a[0], id, "SweptCurve"), depth + 1);
      const Affine P = axis_placement(a[1], id);
      const Vector3d v = direction(ref(a[2], id, "ExtrudedDirection")) * num(a[3], id, "Depth");
      Soup local;
      for (const auto& l : pr.loops) {
        const std::size_t m = pr.closed ? l.size() : l.size() - 1;
        for (std::size_t i = 0; i < m && l.size() >= 2; ++i) {
          const auto b = static_cast<std::uint32_t>(local.v.size());
          const Vector3d p0(l[i].x(), l[i].y(), 0), p1(l[(i + 1) % l.size()].x(), l[(i + 1) % l.size()].y(), 0);
          local.v.insert(local.v.end(), {p0, p1, p1 + v, p0 + v});
          local.t.push_back({b, b + 1, b + 2});
          local.t.push_back({b, b + 2, b + 3});
        }
      }
      s.append(local, P);
    } else if (t == "IFCFACE") {
      face(id, s);
    } else if (t == "IFCSTYLEDITEM" || t == "IFCBOUNDINGBOX" || t == "IFCGEOMETRICCURVESET" ||
               t == "IFCGEOMETRICSET" || t == "IFCANNOTATIONFILLAREA" || t == "IFCTEXTLITERAL" ||
               t == "IFCPOLYLINE" || t == "IFCCARTESIANPOINT") {
      // Not surface geometry: ignored.
    } else {
      unsupported(id);
    }
  }

  /// Body representations of a product definition shape (Body, else Facetation, else solid types).
  std::vector<std::uint32_t> body_representations(std::uint32_t pds) {
    std::vector<std::uint32_t> body, facet, other;
    if (f_.type_of(pds) != "IFCPRODUCTDEFINITIONSHAPE" && f_.type_of(pds) != "IFCPRODUCTREPRESENTATION") return body;
    const Args a = args_of(pds, 3);
    if (!a[2].is_list()) fail(pds, "Representations must be a list");
    for (const auto& r : a[2].items) {
      const std::uint32_t rid = ref(r, pds, "representation");
      if (f_.type_of(rid) != "IFCSHAPEREPRESENTATION") continue;
      const Args ra = args_of(rid, 4);
      const std::string ident = ra[1].kind == StepValue::Kind::kString ? ra[1].text : "";
      const std::string type = ra[2].kind == StepValue::Kind::kString ? ra[2].text : "";
      if (ident == "Body") {
        body.push_back(rid);
      } else if (ident == "Facetation") {
        facet.push_back(rid);
      } else if (ident.empty() && (type == "SweptSolid" || type == "Brep" || type == "SurfaceModel" ||
                                   type == "Tessellation" || type == "Clipping" || type == "CSG" ||
                                   type == "MappedRepresentation" || type == "SolidModel")) {
        other.push_back(rid);
      }
    }
    if (!body.empty()) return body;
    if (!facet.empty()) return facet;
    return other;
  }

  /// Opening volumes of an opening element in world (file-unit) coordinates.
  void opening_volumes(std::uint32_t opening, std::vector<Volume>& out) {
    const Args a = args_of(opening, 7);
    const Affine T = a[5].is_null() ? Affine::Identity() : local_placement(ref(a[5], opening, "ObjectPlacement"), 0);
    if (a[6].is_null()) return;
    for (std::uint32_t rep : body_representations(ref(a[6], opening, "Representation"))) {
      const Args ra = args_of(rep, 4);
      if (!ra[3].is_list()) continue;
      for (const auto& it : ra[3].items) collect_volumes(ref(it, rep, "item"), T, out, 1);
    }
  }

  void collect_volumes(std::uint32_t id, const Affine& T, std::vector<Volume>& out, int depth) {
    check_depth(id, depth);
    const std::string& t = f_.type_of(id);
    if (t == "IFCMAPPEDITEM") {
      const Args a = args_of(id, 2);
      const std::uint32_t map = ref(a[0], id, "MappingSource");
      const Args ma = args_of(map, 2);
      const Affine M = T * transformation_operator(ref(a[1], id, "MappingTarget")) * axis_placement(ma[0], map);
      const Args ra = args_of(ref(ma[1], map, "MappedRepresentation"), 4);
      if (!ra[3].is_list()) return;
      for (const auto& it : ra[3].items) collect_volumes(ref(it, ma[1].ref, "item"), M, out, depth + 1);
    } else if (t == "IFCBOOLEANCLIPPINGRESULT" || t == "IFCBOOLEANRESULT") {
      const Args a = args_of(id, 3);
      collect_volumes(ref(a[1], id, "FirstOperand"), T, out, depth + 1);
    } else if (t == "IFCSTYLEDITEM" || t == "IFCBOUNDINGBOX") {
    } else {
      Volume v = volume(id, depth + 1);
      v.apply(T);
      out.push_back(std::move(v));
    }
  }

  friend BimMesh build_mesh(const IfcModel&, const BimMeshSettings&);
};

bool is_excluded_type(const std::string& t, bool include_spaces) {
  static const std::unordered_set<std::string> kExcluded = {
      "IFCOPENINGELEMENT", "IFCOPENINGSTANDARDCASE", "IFCSITE", "IFCBUILDING", "IFCBUILDINGSTOREY",
      "IFCPROJECT", "IFCANNOTATION", "IFCVIRTUALELEMENT", "IFCGRID", "IFCSPATIALZONE",
      "IFCEXTERNALSPATIALELEMENT", "IFCFACILITY", "IFCFACILITYPART", "IFCBRIDGE", "IFCROAD",
      "IFCALIGNMENT", "IFCSTRUCTURALPOINTCONNECTION", "IFCSTRUCTURALCURVEMEMBER", ""};
  if (t == "IFCSPACE") return !include_spaces;
  return kExcluded.count(t) != 0;
}

BimMesh Builder::run() {
  // 1. Which types are products (ObjectPlacement at 5, Representation at 6)?
  std::vector<bool> product_type(f_.type_names().size(), false);
  {
    std::vector<int> probed(f_.type_names().size(), 0);
    for (const auto& e : f_.entities()) {
      if (probed[e.type] >= 3 || product_type[e.type]) continue;
      const std::string& t = f_.type_names()[e.type];
      if (t.rfind("IFC", 0) != 0 || is_excluded_type(t, settings_.include_spaces)) {
        probed[e.type] = 3;
        continue;
      }
      ++probed[e.type];
      Args a;
      try {
        a = f_.args(e);
      } catch (const Error&) {
        continue;
      }
      if (a.size() < 7) {
        probed[e.type] = 3;
        continue;
      }
      const bool placement = a[5].is_ref() && f_.type_of(a[5].ref) == "IFCLOCALPLACEMENT";
      const bool shape = a[6].is_ref() && f_.type_of(a[6].ref) == "IFCPRODUCTDEFINITIONSHAPE";
      if (placement || shape) product_type[e.type] = true;
    }
  }
  const double scale = units_.length_to_m;

  // 2. Storeys.
  std::unordered_map<std::uint32_t, int> storey_index;
  for (std::uint32_t sid : f_.ids_of_type("IFCBUILDINGSTOREY")) {
    BimStorey st;
    st.express_id = sid;
    try {
      const Args a = args_of(sid, 6);
      st.name = a[2].kind == StepValue::Kind::kString ? a[2].text : "";
      if (a[5].is_ref()) st.elevation = local_placement(a[5].ref, 0).translation().z() * scale;
    } catch (const Error& e) {
      mesh_.warnings.push_back(e.what());
    }
    mesh_.storeys.push_back(st);
  }
  std::stable_sort(mesh_.storeys.begin(), mesh_.storeys.end(),
                   [](const BimStorey& x, const BimStorey& y) { return x.elevation < y.elevation; });
  for (std::size_t i = 0; i < mesh_.storeys.size(); ++i) storey_index[mesh_.storeys[i].express_id] = static_cast<int>(i);

  // 3. Containment and aggregation.
  std::unordered_map<std::uint32_t, std::uint32_t> container, parent;
  for (std::uint32_t rid : f_.ids_of_type("IFCRELCONTAINEDINSPATIALSTRUCTURE")) {
    try {
      const Args a = args_of(rid, 6);
      if (!a[4].is_list() || !a[5].is_ref()) continue;
      for (const auto& el : a[4].items) {
        if (el.is_ref()) container[el.ref] = a[5].ref;
      }
    } catch (const Error& e) {
      mesh_.warnings.push_back(e.what());
    }
  }
  for (std::uint32_t rid : f_.ids_of_type("IFCRELAGGREGATES")) {
    try {
      const Args a = args_of(rid, 6);
      if (!a[4].is_ref() || !a[5].is_list()) continue;
      for (const auto& el : a[5].items) {
        if (el.is_ref()) parent[el.ref] = a[4].ref;
      }
    } catch (const Error& e) {
      mesh_.warnings.push_back(e.what());
    }
  }
  auto storey_of = [&](std::uint32_t id) {
    for (int k = 0; k < settings_.max_depth; ++k) {
      if (auto s = storey_index.find(id); s != storey_index.end()) return s->second;
      if (auto c = container.find(id); c != container.end()) {
        auto s = storey_index.find(c->second);
        return s == storey_index.end() ? -1 : s->second;
      }
      auto p = parent.find(id);
      if (p == parent.end()) return -1;
      id = p->second;
    }
    return -1;
  };
  std::unordered_map<std::uint32_t, std::vector<std::uint32_t>> openings;
  for (std::uint32_t rid : f_.ids_of_type("IFCRELVOIDSELEMENT")) {
    try {
      const Args a = args_of(rid, 6);
      if (a[4].is_ref() && a[5].is_ref()) openings[a[4].ref].push_back(a[5].ref);
    } catch (const Error& e) {
      mesh_.warnings.push_back(e.what());
    }
  }

  // 4. Elements.
  std::vector<Vector3d> verts;  // file units, world
  for (const auto& e : f_.entities()) {
    if (!product_type[e.type]) continue;
    BimElement el;
    el.express_id = e.id;
    el.type = ifc_type_display_name(f_.type_names()[e.type]);
    el.storey = storey_of(e.id);
    Soup s;
    try {
      const Args a = f_.args(e);
      if (a.size() < 7) continue;
      el.global_id = a[0].kind == StepValue::Kind::kString ? a[0].text : "";
      el.name = a[2].kind == StepValue::Kind::kString ? a[2].text : "";
      if (a[6].is_ref()) {
        const auto reps = body_representations(ref(a[6], e.id, "Representation"));
        el.has_body = !reps.empty();
        if (el.has_body) {
          const Affine T = a[5].is_ref() ? local_placement(a[5].ref, 0) : Affine::Identity();
          Soup local;
          for (std::uint32_t rep : reps) representation_items(rep, local, 1);
          s.append(local, T);
        }
      }
    } catch (const Error& err) {
      mesh_.warnings.push_back(err.what());
      s = Soup{};
    }
    if (settings_.subtract_openings && !s.t.empty()) {
      auto it = openings.find(e.id);
      if (it != openings.end()) {
        for (std::uint32_t op : it->second) {
          try {
            std::vector<Volume> vols;
            opening_volumes(op, vols);
            for (auto& v : vols) {
              v.margin = 100.0 * eps_;  // faces flush with the opening are cut too
              const Soup reveals = reveal_faces(s, v, eps_);
              subtract_volume(s, v, eps_);
              s.append(reveals, Affine::Identity());
            }
          } catch (const Error& err) {
            mesh_.warnings.push_back(std::string(err.what()) + " (opening of #" + std::to_string(e.id) + " ignored)");
          }
        }
      }
    }
    // Compact: keep only referenced vertices; drop non-finite triangles.
    el.first_triangle = mesh_.triangles.size();
    std::vector<std::uint32_t> remap(s.v.size(), std::numeric_limits<std::uint32_t>::max());
    const auto elem_index = static_cast<std::int32_t>(mesh_.elements.size());
    for (const Tri& t : s.t) {
      if (!s.v[t[0]].allFinite() || !s.v[t[1]].allFinite() || !s.v[t[2]].allFinite()) continue;
      Tri out;
      for (int k = 0; k < 3; ++k) {
        std::uint32_t& r = remap[t[static_cast<std::size_t>(k)]];
        if (r == std::numeric_limits<std::uint32_t>::max()) {
          r = static_cast<std::uint32_t>(verts.size());
          verts.push_back(s.v[t[static_cast<std::size_t>(k)]]);
        }
        out[static_cast<std::size_t>(k)] = r;
      }
      mesh_.triangles.push_back(out);
      mesh_.triangle_element.push_back(elem_index);
    }
    el.num_triangles = mesh_.triangles.size() - el.first_triangle;
    mesh_.elements.push_back(std::move(el));
  }
  for (const auto& [type, info] : unsupported_) {
    mesh_.warnings.push_back(f_.where(info.second) + ": unsupported " + type + " #" + std::to_string(info.second) +
                             (info.first > 1 ? " (and " + std::to_string(info.first - 1) + " more)" : std::string()) +
                             " skipped");
  }

  // 5. Metres, origin offset, element bounds.
  Vector3d lo = Vector3d::Constant(kInf), hi = -lo;
  for (auto& v : verts) {
    v *= scale;
    lo = lo.cwiseMin(v);
    hi = hi.cwiseMax(v);
  }
  if (!verts.empty()) {
    const double far = std::max(lo.cwiseAbs().maxCoeff(), hi.cwiseAbs().maxCoeff());
    if (far > settings_.offset_threshold) {
      const Vector3d c = 0.5 * (lo + hi);
      const double r = settings_.offset_rounding > 0 ? settings_.offset_rounding : 1.0;
      for (int k = 0; k < 3; ++k) mesh_.origin_offset[k] = std::round(c[k] / r) * r;
      for (auto& v : verts) v -= mesh_.origin_offset;
      for (auto& st : mesh_.storeys) st.elevation -= mesh_.origin_offset.z();
    }
  }
  mesh_.vertices = std::move(verts);
  for (auto& el : mesh_.elements) {
    for (std::size_t t = el.first_triangle; t < el.first_triangle + el.num_triangles; ++t) {
      for (std::uint32_t k : mesh_.triangles[t]) {
        el.bbox_min = el.bbox_min.cwiseMin(mesh_.vertices[k]);
        el.bbox_max = el.bbox_max.cwiseMax(mesh_.vertices[k]);
      }
    }
  }
  return std::move(mesh_);
}

}  // namespace

BimMesh build_mesh(const IfcModel& model, const BimMeshSettings& settings) {
  PLUMB_CHECK(settings.circle_segments >= 3, "build_mesh: circle_segments must be >= 3");
  PLUMB_CHECK(settings.max_depth > 0, "build_mesh: max_depth must be > 0");
  Builder b(model, settings);
  return b.run();
}

}  // namespace plumb::bim
