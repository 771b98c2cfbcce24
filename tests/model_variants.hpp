// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Variants of a building mesh shaped like real architectural exports, made from the shared
/// models in the tests: elements of some IFC types removed (the ground slab kept in the structural
/// model, floors not modelled at all).

#include <algorithm>
#include <string>
#include <vector>

#include "plumb/bim/mesh.hpp"

namespace plumb::test {

/// `mesh` without the triangles of the elements whose type is in `types` (the elements stay, with no
/// triangles, so element and storey indices are unchanged).
inline bim::BimMesh without_types(const bim::BimMesh& mesh, const std::vector<std::string>& types) {
  bim::BimMesh out = mesh;
  out.triangles.clear();
  out.triangle_element.clear();
  for (std::size_t e = 0; e < mesh.elements.size(); ++e) {
    bim::BimElement& el = out.elements[e];
    const bool drop = std::find(types.begin(), types.end(), el.type) != types.end();
    const std::size_t first = el.first_triangle, count = el.num_triangles;
    el.first_triangle = out.triangles.size();
    el.num_triangles = 0;
    if (drop) continue;
    for (std::size_t t = first; t < first + count && t < mesh.triangles.size(); ++t) {
      out.triangles.push_back(mesh.triangles[t]);
      out.triangle_element.push_back(static_cast<std::int32_t>(e));
      ++el.num_triangles;
    }
  }
  return out;
}

}  // namespace plumb::test
