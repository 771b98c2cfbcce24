// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Planar polygon helpers for IFC meshing: signed area, point-in-polygon, ear clipping with holes.

#include <array>
#include <cstdint>
#include <vector>

#include "plumb/core/types.hpp"

namespace plumb::bim {

/// @brief Signed area of a closed polygon (positive when counter-clockwise).
double signed_area(const std::vector<Vector2d>& loop);

/// @brief Even-odd point-in-polygon over several loops (outer + holes).
bool point_in_loops(const Vector2d& p, const std::vector<std::vector<Vector2d>>& loops);

/// @brief Triangulate a polygon with holes by ear clipping (holes are bridged to the outer loop).
/// @param loops loop 0 = outer boundary, loops 1.. = holes; any orientation; the closing point must
///        not repeat the first one.
/// @return triangles as indices into the concatenation of `loops`, counter-clockwise in the plane.
/// @note O(n^2) in the number of vertices; degenerate (collinear) input yields fewer triangles,
///       never an exception.
std::vector<std::array<std::uint32_t, 3>> triangulate_polygon(const std::vector<std::vector<Vector2d>>& loops);

}  // namespace plumb::bim
