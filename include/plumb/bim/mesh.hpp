// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief IFC geometry to a labelled triangle mesh (Liu et al. 2022, sec. 1.1).

#include <array>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "plumb/bim/ifc.hpp"
#include "plumb/core/types.hpp"

namespace plumb::bim {

/// @brief A building storey (IfcBuildingStorey).
struct BimStorey {
  std::uint32_t express_id = 0;
  std::string name;
  double elevation = 0.0;  ///< z of the storey placement in the mesh frame [m]
};

/// @brief One IFC product (wall, slab, door...) and its triangles in the mesh.
struct BimElement {
  std::uint32_t express_id = 0;
  std::string global_id;
  std::string type;       ///< mixed case, e.g. "IfcWallStandardCase"
  std::string name;
  int storey = -1;        ///< index into BimMesh::storeys, -1 when not in a storey
  std::size_t first_triangle = 0;  ///< triangles [first_triangle, first_triangle + num_triangles)
  std::size_t num_triangles = 0;
  Vector3d bbox_min = Vector3d::Constant(std::numeric_limits<double>::infinity());   ///< mesh frame [m]
  Vector3d bbox_max = Vector3d::Constant(-std::numeric_limits<double>::infinity());  ///< mesh frame [m]
  bool has_body = false;  ///< the product has a Body representation
};

/// @brief Triangle mesh of a building, each triangle tagged with its element.
///
/// Frame: the IFC world frame in metres minus `origin_offset` (zero unless the model lies farther
/// than BimMeshSettings::offset_threshold from the origin).
struct BimMesh {
  std::vector<Vector3d> vertices;                   ///< [m], mesh frame
  std::vector<std::array<std::uint32_t, 3>> triangles;  ///< counter-clockwise seen from outside where known
  std::vector<std::int32_t> triangle_element;       ///< element index per triangle
  std::vector<BimElement> elements;
  std::vector<BimStorey> storeys;                   ///< sorted by elevation
  Vector3d origin_offset = Vector3d::Zero();        ///< IFC world = mesh frame + origin_offset [m]
  std::vector<std::string> warnings;                ///< unsupported entities etc., each naming the entity

  std::size_t num_triangles() const { return triangles.size(); }
  /// @brief Axis-aligned bounds of all vertices (mesh frame).
  void bounds(Vector3d& lo, Vector3d& hi) const;
  /// @brief Index of an element by express id, -1 if absent.
  int find_element(std::uint32_t express_id) const;
};

/// @brief Settings of build_mesh().
struct BimMeshSettings {
  bool subtract_openings = true;     ///< cut IfcOpeningElement volumes out of their host elements
  bool include_spaces = false;       ///< also mesh IfcSpace volumes
  double offset_threshold = 1000.0;  ///< [m] re-centre when |coordinate| exceeds this
  double offset_rounding = 100.0;    ///< [m] origin_offset is a multiple of this
  int circle_segments = 24;          ///< polygon segments of a full circle
  int max_depth = 48;                ///< reference-chain depth limit (cycles -> warning)
};

/// @brief Settings for the mesh of a building a robot drives in: with its rooms (IfcSpace), whose
///        footprints floor_plan() takes where the floors are not modelled; the simulator, the BIM
///        cloud and the floor plan's obstacles leave them out.
inline BimMeshSettings mesh_settings_with_spaces() {
  BimMeshSettings s;
  s.include_spaces = true;
  return s;
}

/// @brief Mesh every product with a Body representation.
/// @return the mesh; problems with single entities are collected in BimMesh::warnings.
/// @throws plumb::Error only for problems with the whole model (none today besides misuse).
BimMesh build_mesh(const IfcModel& model, const BimMeshSettings& settings = {});

}  // namespace plumb::bim
