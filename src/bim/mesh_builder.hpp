// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Private to build_mesh(): the Builder that walks an IFC model's products and meshes their
///        Body representations into a BimMesh. Its members are defined by concern: STEP access,
///        points and placements in mesh_placement.cpp; curves and profiles in mesh_profiles.cpp;
///        solids, surfaces, boolean results, mapped items and opening volumes in mesh_solids.cpp;
///        the model-wide stages (storeys, containment, voids, the elements, units) in mesh.cpp.
///        Not installed; not part of the API.

#include <cstddef>
#include <cstdint>
#include <map>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "mesh_csg.hpp"
#include "plumb/bim/ifc.hpp"
#include "plumb/bim/mesh.hpp"
#include "plumb/bim/step.hpp"

namespace plumb::bim::mesh_detail {

using Args = std::vector<StepValue>;

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
  // The model's structure, read by run() before the elements.
  std::unordered_map<std::uint32_t, int> storey_index_;                     // storey -> index in mesh_.storeys
  std::unordered_map<std::uint32_t, std::uint32_t> container_;              // element -> its spatial structure
  std::unordered_map<std::uint32_t, std::uint32_t> parent_;                 // part -> the whole it belongs to
  std::unordered_map<std::uint32_t, std::vector<std::uint32_t>> openings_;  // element -> its opening elements

  // ---- the stages of run() (mesh.cpp) ----------------------------------------------------------
  std::vector<bool> product_types() const;
  void read_storeys();
  void read_containment();
  void read_voids();
  int storey_of(std::uint32_t id) const;
  void mesh_elements(const std::vector<bool>& product_type, std::vector<Vector3d>& verts);
  bool element_body(const StepEntity& e, BimElement& el, Soup& s);
  void subtract_openings(std::uint32_t element, Soup& s);
  void add_element(BimElement el, const Soup& s, std::vector<Vector3d>& verts);
  void report_unsupported();
  void finish(std::vector<Vector3d> verts);

  // ---- helpers, points and placements (mesh_placement.cpp) ------------------------------------
  [[noreturn]] void fail(std::uint32_t id, const std::string& msg) const;
  void check_depth(std::uint32_t id, int depth) const;
  Args args_of(std::uint32_t id, std::size_t min_args) const;
  std::uint32_t ref(const StepValue& v, std::uint32_t owner, const char* what) const;
  double num(const StepValue& v, std::uint32_t owner, const char* what) const;
  void unsupported(std::uint32_t id);
  Vector3d point3(std::uint32_t id) const;
  Vector3d direction(std::uint32_t id) const;
  Vector3d opt_dir(const StepValue& v, std::uint32_t owner, const Vector3d& dflt) const;
  static Eigen::Matrix3d frame_from(const Vector3d& z_in, const Vector3d& x_in);
  Affine axis_placement(const StepValue& v, std::uint32_t owner) const;
  Affine local_placement(std::uint32_t id, int depth);
  Affine transformation_operator(std::uint32_t id) const;

  // ---- curves and profiles (mesh_profiles.cpp) -------------------------------------------------
  int arc_segments(double sweep) const;
  static void push_unique(Loop2& out, const Vector2d& p);
  void arc_points(const Vector2d& c, double r, double a0, double a1, Loop2& out) const;
  void curve(std::uint32_t id, Loop2& out, int depth);
  void three_point_arc(const Vector2d& p1, const Vector2d& p2, const Vector2d& p3, Loop2& out) const;
  void trimmed_curve(std::uint32_t id, Loop2& out, int depth);
  static void close_loop(Loop2& l);
  Profile profile(std::uint32_t id, int depth);

  // ---- solids, surfaces and opening volumes (mesh_solids.cpp) ----------------------------------
  static void add_polygon3(Soup& s, const std::vector<std::vector<Vector3d>>& loops3);
  void extrusion(std::uint32_t id, Soup& s, int depth);
  void face(std::uint32_t id, Soup& s);
  void face_set(std::uint32_t id, Soup& s);
  void tessellated(std::uint32_t id, Soup& s);
  Volume volume(std::uint32_t id, int depth);
  void boolean_result(std::uint32_t id, Soup& s, int depth);
  void mapped_item(std::uint32_t id, Soup& s, int depth);
  void representation_items(std::uint32_t rep, Soup& s, int depth);
  void item(std::uint32_t id, Soup& s, int depth);
  std::vector<std::uint32_t> body_representations(std::uint32_t pds);
  void opening_volumes(std::uint32_t opening, std::vector<Volume>& out);
  void collect_volumes(std::uint32_t id, const Affine& T, std::vector<Volume>& out, int depth);
};

}  // namespace plumb::bim::mesh_detail
