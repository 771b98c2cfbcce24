// SPDX-License-Identifier: BSD-3-Clause
// The CSG behind build_mesh(): a triangle soup, and the removal volumes (IfcOpeningElement bodies,
// the second operand of an IfcBooleanClippingResult) cut out of it. A volume is a half-space and/or
// a prism in its own frame; subtract_volume() splits the soup's triangles along the volume's planes
// and drops the pieces whose material lies inside, and reveal_faces() builds the parts of the
// volume's boundary inside the solid, so that the difference stays closed.
#include "mesh_csg.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

#include "plumb/bim/polygon.hpp"

namespace plumb::bim::mesh_detail {

void Soup::append(const Soup& o, const Affine& T) {
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

bool Volume::near_boundary(const Vector2d& q, double m) const {
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

bool Volume::inside(const Vector3d& x, double eps) const {
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

std::vector<std::pair<Eigen::Vector4d, bool>> Volume::planes() const {
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

bool Volume::bounds(Vector3d& lo, Vector3d& hi) const {
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

namespace {

/// Which sides of a plane a polygon has vertices on, beyond the tolerance.
struct PlaneSides {
  bool pos = false;  ///< a vertex lies more than eps on the positive side
  bool neg = false;  ///< a vertex lies more than eps on the negative side
};

/// The signed distances `d` of the vertices of `poly` to the plane n . x + offset = 0, and the sides
/// it has vertices on beyond `eps`.
template <typename Normal>
PlaneSides plane_distances(const std::vector<Vector3d>& poly, const Normal& n, double offset, double eps,
                           std::vector<double>& d) {
  PlaneSides sides;
  d.resize(poly.size());
  for (std::size_t i = 0; i < poly.size(); ++i) {
    d[i] = n.dot(poly[i]) + offset;
    sides.pos |= d[i] > eps;
    sides.neg |= d[i] < -eps;
  }
  return sides;
}

/// Cuts `poly`, whose vertices lie at the signed distances `d` from a plane, into its part on the
/// positive side (`pos_part`) and its part on the negative side (`neg_part`): a vertex within `eps`
/// of the plane goes to both, and so does the crossing point of an edge from one side to the other.
void split_polygon(const std::vector<Vector3d>& poly, const std::vector<double>& d, double eps,
                   std::vector<Vector3d>& pos_part, std::vector<Vector3d>& neg_part) {
  for (std::size_t i = 0; i < poly.size(); ++i) {
    const std::size_t j = (i + 1) % poly.size();
    const double di = d[i], dj = d[j];
    if (di >= -eps) pos_part.push_back(poly[i]);
    if (di <= eps) neg_part.push_back(poly[i]);
    if ((di > eps && dj < -eps) || (di < -eps && dj > eps)) {
      const Vector3d x = poly[i] + (poly[j] - poly[i]) * (di / (di - dj));
      pos_part.push_back(x);
      neg_part.push_back(x);
    }
  }
}

}  // namespace

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
        const PlaneSides sides = plane_distances(poly, pl.head<3>(), pl[3], eps, d);
        if (!sides.neg) {  // outside this plane (or on it: decided by the centroid test)
          (exclusive && sides.pos ? done : next).push_back(std::move(poly));
          continue;
        }
        if (!sides.pos) {
          next.push_back(std::move(poly));
          continue;
        }
        std::vector<Vector3d> P, N;
        split_polygon(poly, d, eps, P, N);
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

void split_by_plane(std::vector<std::vector<Vector3d>>& polys, const Vector3d& n, double d, double eps) {
  std::vector<std::vector<Vector3d>> out;
  out.reserve(polys.size());
  std::vector<double> dist;
  for (auto& poly : polys) {
    const PlaneSides sides = plane_distances(poly, n, d, eps, dist);
    if (!sides.pos || !sides.neg) {
      out.push_back(std::move(poly));
      continue;
    }
    std::vector<Vector3d> P, N;
    split_polygon(poly, dist, eps, P, N);
    if (P.size() >= 3) out.push_back(std::move(P));
    if (N.size() >= 3) out.push_back(std::move(N));
  }
  polys.swap(out);
}

namespace {

/// The candidate faces of reveal_faces(): the volume's boundary within the box [alo, ahi] around the
/// solid (the half-space plane as a square covering it, the prism sides and caps), each with its
/// normal pointing into the volume.
std::vector<std::vector<Vector3d>> reveal_candidates(const Volume& vol, const Vector3d& alo, const Vector3d& ahi) {
  const Affine from_local = vol.to_local.inverse();
  const bool mirrored = from_local.linear().determinant() < 0.0;
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
      const Vector3d p((corner & 1) ? ahi.x() : alo.x(), (corner & 2) ? ahi.y() : alo.y(),
                       (corner & 4) ? ahi.z() : alo.z());
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
  return faces;
}

/// The planes of the solid's triangles within `tol` of the box [blo, bhi], as (n, d) with one sign
/// per plane, each plane once.
std::vector<Eigen::Vector4d> face_planes_near(const Soup& s, const Vector3d& blo, const Vector3d& bhi, double tol,
                                              double eps) {
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
  return planes;
}

}  // namespace

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
  // Candidate faces: each with its normal pointing into the volume.
  std::vector<std::vector<Vector3d>> faces = reveal_candidates(vol, alo, ahi);
  Vector3d blo = alo, bhi = ahi;
  Vector3d vlo, vhi;
  if (vol.bounds(vlo, vhi)) {
    blo = blo.cwiseMax(vlo);
    bhi = bhi.cwiseMin(vhi);
  }
  // Split them along the planes of the solid's faces near the volume: every piece then lies
  // entirely inside or entirely outside the solid.
  const double tol = eps + std::max(vol.margin, 0.0);
  const std::vector<Eigen::Vector4d> planes = face_planes_near(s, blo, bhi, tol, eps);
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

}  // namespace plumb::bim::mesh_detail
