// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief BIM mesh -> point cloud (surface sampling) and floor-plan slices (Liu et al. 2022,
///        sec. 1.1 and Fig. 8).

#include <cstdint>
#include <string>
#include <vector>

#include "plumb/bim/mesh.hpp"
#include "plumb/core/point_cloud.hpp"

namespace plumb::bim {

/// @brief Which elements to use (shared by sampling and slicing).
struct ElementFilter {
  std::vector<std::string> types;  ///< IFC types to keep, case-insensitive ("IfcWall"); empty = all
  int storey = -1;                 ///< storey index to keep (BimMesh::storeys); -1 = all
};

/// @brief True when element `index` of `mesh` passes `filter`.
bool element_selected(const BimMesh& mesh, std::size_t index, const ElementFilter& filter);

/// @brief Storey index from a name (exact, then case-insensitive) or a decimal index.
/// @throws plumb::Error listing the storeys when nothing matches.
int find_storey(const BimMesh& mesh, const std::string& name_or_index);

/// @brief Settings of sample_surface().
struct SurfaceSampleSettings {
  double spacing = 0.05;       ///< mean point spacing [m]: one point per spacing^2 of area
  std::uint64_t seed = 42;     ///< random seed; equal seeds give equal clouds
  ElementFilter filter;        ///< elements to sample
};

/// @brief Area-uniform random points on the mesh triangles with normals and element labels.
/// @return cloud in the mesh frame; `labels` = element index, `normals` = triangle normals.
/// @note Deterministic for a given seed; O(triangles + points).
PointCloud sample_surface(const BimMesh& mesh, const SurfaceSampleSettings& settings = {});

/// @brief A horizontal cut through the mesh.
struct FloorPlan {
  std::vector<Vector2d> segment_start;       ///< [m], mesh frame x y
  std::vector<Vector2d> segment_end;         ///< [m]
  std::vector<std::int32_t> segment_element; ///< element index per segment
  std::vector<Vector2f> points;              ///< points along the segments [m]
  std::vector<std::int32_t> point_element;   ///< element index per point
};

/// @brief Settings of slice_floor_plan().
struct FloorPlanSettings {
  double point_spacing = 0.05;  ///< spacing of `points` along each segment [m]
  ElementFilter filter;
};

/// @brief Intersect the mesh with the plane z = height.
FloorPlan slice_floor_plan(const BimMesh& mesh, double height, const FloorPlanSettings& settings = {});

}  // namespace plumb::bim
