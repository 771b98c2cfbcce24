// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Ray casting against a triangle mesh: a bounding volume hierarchy built with the binned
/// surface area heuristic and a watertight ray-triangle test (Woop, Benthin, Wald 2013).

#include <array>
#include <cstdint>
#include <limits>
#include <vector>

#include "plumb/core/types.hpp"

namespace plumb::bim {
struct BimMesh;
}

namespace plumb::sim {

/// @brief The first surface a ray meets.
struct RayHit {
  double range = std::numeric_limits<double>::infinity();  ///< distance along the unit ray [m]
  std::uint32_t triangle = ~0u;  ///< index of the triangle hit (in the caster's input), ~0u = none
  std::int32_t element = -1;     ///< element of that triangle (triangle_element), -1 = none
  Vector3d normal = Vector3d::Zero();  ///< unit geometric normal of the triangle, facing the ray origin

  /// @brief True when the ray met a surface.
  bool hit() const { return triangle != ~0u; }
};

/// @brief Settings of the BVH build.
struct RayCasterSettings {
  int leaf_size = 4;  ///< triangles at which a subtree of the binary SAH build always stops (1..255)
  int sah_bins = 32;  ///< bins per axis of the binned SAH split search (2..1024)
};

/// @brief A static triangle mesh prepared for ray queries.
///
/// The hierarchy is built once with binned SAH (O(n log n)) and collapsed into a 4-wide BVH whose
/// children are nodes or single triangles, so one SSE2 step tests four boxes (portable scalar code
/// elsewhere). cast() walks it nearest child first and tests the triangles whose boxes the ray
/// meets with the watertight algorithm of Woop et al. (JCGT 2(1), 2013) in double precision, so a
/// ray through an edge or vertex shared by triangles of a closed surface never slips between them.
/// The float boxes are rounded outward and padded, so they never cull a hit the exact test finds.
/// Both faces of a triangle are hit (no back-face culling).
/// @note cast() is const and keeps no state: it is safe to call from any number of threads.
class RayCaster {
 public:
  /// @brief Build over a triangle soup.
  /// @param vertices positions [m] (finite)
  /// @param triangles vertex indices per triangle
  /// @param triangle_element element per triangle reported in RayHit::element; empty = all -1
  /// @throws plumb::Error for an index out of range, a non-finite vertex, a size mismatch or bad
  ///         settings. An empty mesh is valid: every ray misses.
  RayCaster(std::vector<Vector3d> vertices, std::vector<std::array<std::uint32_t, 3>> triangles,
            std::vector<std::int32_t> triangle_element, const RayCasterSettings& settings = {});

  /// @brief Build over all triangles of a BIM mesh (elements = BimMesh element indices).
  explicit RayCaster(const bim::BimMesh& mesh, const RayCasterSettings& settings = {});

  /// @brief First hit along origin + t * unit_dir for 0 < t < t_max.
  /// @param unit_dir direction of unit length (the range is measured in its units)
  /// @return the hit, or a RayHit with hit() == false (also for a non-finite origin or direction,
  ///         a zero direction, or t_max that is NaN or <= 0).
  RayHit cast(const Vector3d& origin, const Vector3d& unit_dir,
              double t_max = std::numeric_limits<double>::infinity()) const;

  /// @brief True when anything lies on the ray for 0 < t < t_max (any hit, cheaper than cast()).
  bool occluded(const Vector3d& origin, const Vector3d& unit_dir, double t_max) const;

  std::size_t num_triangles() const { return triangles_.size(); }
  const std::vector<Vector3d>& vertices() const { return vertices_; }
  const std::vector<std::array<std::uint32_t, 3>>& triangles() const { return triangles_; }
  const std::vector<std::int32_t>& triangle_element() const { return triangle_element_; }
  /// @brief Number of BVH nodes (diagnostics).
  std::size_t num_nodes() const { return nodes_.size(); }

  /// @brief A 4-wide BVH node: the bounds of its four child slots in float, rounded outward.
  struct alignas(64) Node {
    float bounds[6][4];        ///< rows lo x, hi x, lo y, hi y, lo z, hi z; an empty slot has lo > hi
    std::uint32_t child[4];    ///< node index, or kTriangleBit | leaf slot of a triangle
    std::uint32_t num_children;  ///< slots in use
    std::uint32_t triangle_mask;  ///< bit i set: slot i is a triangle
    std::uint32_t unused[2];
  };
  static constexpr std::uint32_t kTriangleBit = 0x80000000u;

 private:
  template <bool kAnyHit>
  RayHit traverse(const Vector3d& origin, const Vector3d& unit_dir, double t_max) const;
  /// The hit of leaf slot `slot` at `range` along `dir`: its triangle, element and normal.
  RayHit hit_of(std::uint32_t slot, double range, const Vector3d& dir) const;
  void build(const RayCasterSettings& settings);

  std::vector<Vector3d> vertices_;
  std::vector<std::array<std::uint32_t, 3>> triangles_;
  std::vector<std::int32_t> triangle_element_;
  std::vector<Node> nodes_;
  std::vector<double> leaf_vertices_;       ///< 9 doubles per triangle, in leaf order
  std::vector<std::uint32_t> leaf_triangle_;  ///< original triangle index, in leaf order
  int depth_ = 0;                             ///< levels of the 4-wide tree
};

}  // namespace plumb::sim
