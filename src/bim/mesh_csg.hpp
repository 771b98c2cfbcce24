// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Private to build_mesh(): the triangle soup an IFC item is meshed into, the 2D profile of
///        a swept solid, and the removal volume (half-space and/or prism) with the CSG that cuts it
///        out of a soup: subtract_volume() drops what lies inside, reveal_faces() adds the faces the
///        cut creates. Not installed; not part of the API.

#include <array>
#include <cstdint>
#include <limits>
#include <utility>
#include <vector>

#include "plumb/core/types.hpp"

namespace plumb::bim::mesh_detail {

using Affine = Eigen::Transform<double, 3, Eigen::Affine>;
using Loop2 = std::vector<Vector2d>;
using Tri = std::array<std::uint32_t, 3>;
constexpr double kInf = std::numeric_limits<double>::infinity();

/// A triangle soup: vertices and index triangles, counter-clockwise seen from outside where known.
struct Soup {
  std::vector<Vector3d> v;
  std::vector<Tri> t;
  /// Append `o` mapped by T (triangles flipped when T mirrors).
  void append(const Soup& o, const Affine& T);
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

  bool near_boundary(const Vector2d& q, double m) const;

  /// Re-express for use in an outer frame where item coordinates map by T_outer_item.
  void apply(const Affine& T_outer_item) { to_local = to_local * T_outer_item.inverse(); }

  bool inside(const Vector3d& x, double eps) const;

  /// Splitting planes in the outer frame, as (n, d) with n normalised and the volume on the
  /// negative side; `w` of the second vector is 1 when the positive side is entirely outside the
  /// volume (half-space, caps, edges of a convex boundary).
  std::vector<std::pair<Eigen::Vector4d, bool>> planes() const;

  /// Bounds in the outer frame when the prism is bounded.
  bool bounds(Vector3d& lo, Vector3d& hi) const;
};

/// Remove the parts of the triangles inside `vol` (triangles are split along the volume's planes).
void subtract_volume(Soup& s, const Volume& vol, double eps);

/// Generalised winding number of a triangle soup around p (Jacobson et al. 2013: the solid angles
/// of the triangles, Van Oosterom and Strackee 1983): about +-1 inside a closed surface, 0 outside.
double winding_number(const Soup& s, const Vector3d& p);

/// Split convex polygons by a plane (n, d): pieces on either side, `eps` thick plane.
void split_by_plane(std::vector<std::vector<Vector3d>>& polys, const Vector3d& n, double d, double eps);

/// The faces a subtraction of `vol` from the solid bounded by `s` creates: the parts of the volume's
/// boundary inside the solid (the reveals of a door or window opening, the back of a niche, the cut
/// face of a clipping half-space), oriented towards the removed volume. Add them to the result of
/// subtract_volume() to keep the element closed (boolean difference: boundary = (boundary of A
/// outside B) + (boundary of B inside A, reversed)).
Soup reveal_faces(const Soup& s, const Volume& vol, double eps);

}  // namespace plumb::bim::mesh_detail
