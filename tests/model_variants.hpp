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

/// `mesh` without the slabs and floor coverings whose top lies at storey `storey`'s floor (within
/// -0.6 .. +0.25 m of its elevation): an export whose ground slab is in the structural model. The
/// slabs above (the ceilings) stay.
inline bim::BimMesh without_floor_slabs(const bim::BimMesh& mesh, int storey) {
  const double z = mesh.storeys.at(static_cast<std::size_t>(storey)).elevation;
  bim::BimMesh marked = mesh;
  for (bim::BimElement& e : marked.elements) {
    const bool floor_type = e.type == "IfcSlab" || e.type == "IfcSlabStandardCase" || e.type == "IfcCovering";
    if (floor_type && e.bbox_max.z() >= z - 0.6 && e.bbox_max.z() <= z + 0.25) e.type = "(removed floor)";
  }
  bim::BimMesh out = without_types(marked, {"(removed floor)"});
  for (std::size_t k = 0; k < out.elements.size(); ++k) out.elements[k].type = mesh.elements[k].type;
  return out;
}

}  // namespace plumb::test
