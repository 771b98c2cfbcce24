// SPDX-License-Identifier: BSD-3-Clause
// build_mesh() and the BimMesh methods. The Builder (mesh_builder.hpp) runs in stages: which entity
// types are products, the storeys, the containment and aggregation that put an element in a storey,
// the openings that void an element, then each product's body meshed, its openings cut out and its
// triangles appended, and last the conversion to metres, the origin offset and the element bounds.
#include "plumb/bim/mesh.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <unordered_set>
#include <utility>
#include <vector>

#include "mesh_builder.hpp"
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

namespace mesh_detail {

namespace {

bool is_excluded_type(const std::string& t, bool include_spaces) {
  static const std::unordered_set<std::string> kExcluded = {
      "IFCOPENINGELEMENT", "IFCOPENINGSTANDARDCASE", "IFCSITE", "IFCBUILDING", "IFCBUILDINGSTOREY",
      "IFCPROJECT", "IFCANNOTATION", "IFCVIRTUALELEMENT", "IFCGRID", "IFCSPATIALZONE",
      "IFCEXTERNALSPATIALELEMENT", "IFCFACILITY", "IFCFACILITYPART", "IFCBRIDGE", "IFCROAD",
      "IFCALIGNMENT", "IFCSTRUCTURALPOINTCONNECTION", "IFCSTRUCTURALCURVEMEMBER", ""};
  if (t == "IFCSPACE") return !include_spaces;
  return kExcluded.count(t) != 0;
}

}  // namespace

BimMesh Builder::run() {
  const std::vector<bool> product_type = product_types();
  read_storeys();
  read_containment();
  read_voids();
  std::vector<Vector3d> verts;  // file units, world
  mesh_elements(product_type, verts);
  report_unsupported();
  finish(std::move(verts));
  return std::move(mesh_);
}

/// Which types are products (ObjectPlacement at 5, Representation at 6)? Up to three instances of
/// each type are probed.
std::vector<bool> Builder::product_types() const {
  std::vector<bool> product_type(f_.type_names().size(), false);
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
  return product_type;
}

/// Storeys, sorted by elevation.
void Builder::read_storeys() {
  const double scale = units_.length_to_m;
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
  for (std::size_t i = 0; i < mesh_.storeys.size(); ++i) {
    storey_index_[mesh_.storeys[i].express_id] = static_cast<int>(i);
  }
}

/// Containment and aggregation.
void Builder::read_containment() {
  for (std::uint32_t rid : f_.ids_of_type("IFCRELCONTAINEDINSPATIALSTRUCTURE")) {
    try {
      const Args a = args_of(rid, 6);
      if (!a[4].is_list() || !a[5].is_ref()) continue;
      for (const auto& el : a[4].items) {
        if (el.is_ref()) container_[el.ref] = a[5].ref;
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
        if (el.is_ref()) parent_[el.ref] = a[4].ref;
      }
    } catch (const Error& e) {
      mesh_.warnings.push_back(e.what());
    }
  }
}

/// The openings that void each element (IfcRelVoidsElement).
void Builder::read_voids() {
  for (std::uint32_t rid : f_.ids_of_type("IFCRELVOIDSELEMENT")) {
    try {
      const Args a = args_of(rid, 6);
      if (a[4].is_ref() && a[5].is_ref()) openings_[a[4].ref].push_back(a[5].ref);
    } catch (const Error& e) {
      mesh_.warnings.push_back(e.what());
    }
  }
}

/// Index of the storey an element is in (itself, its container or the container of a whole it is
/// part of), -1 when none.
int Builder::storey_of(std::uint32_t id) const {
  for (int k = 0; k < settings_.max_depth; ++k) {
    if (auto s = storey_index_.find(id); s != storey_index_.end()) return s->second;
    if (auto c = container_.find(id); c != container_.end()) {
      auto s = storey_index_.find(c->second);
      return s == storey_index_.end() ? -1 : s->second;
    }
    auto p = parent_.find(id);
    if (p == parent_.end()) return -1;
    id = p->second;
  }
  return -1;
}

/// Elements: every product meshed, its openings cut out, its triangles appended to the mesh.
void Builder::mesh_elements(const std::vector<bool>& product_type, std::vector<Vector3d>& verts) {
  for (const auto& e : f_.entities()) {
    if (!product_type[e.type]) continue;
    BimElement el;
    el.express_id = e.id;
    el.type = ifc_type_display_name(f_.type_names()[e.type]);
    el.storey = storey_of(e.id);
    Soup s;
    if (!element_body(e, el, s)) continue;
    if (settings_.subtract_openings && !s.t.empty()) subtract_openings(e.id, s);
    add_element(std::move(el), s, verts);
  }
}

/// The element's attributes and its body in world (file-unit) coordinates; a failure is a warning
/// and leaves the body empty. False when the entity has fewer than 7 arguments (not a product).
bool Builder::element_body(const StepEntity& e, BimElement& el, Soup& s) {
  try {
    const Args a = f_.args(e);
    if (a.size() < 7) return false;
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
  return true;
}

/// Cut the element's openings out of its body, adding the reveals; an opening that fails is a
/// warning and is skipped.
void Builder::subtract_openings(std::uint32_t element, Soup& s) {
  auto it = openings_.find(element);
  if (it == openings_.end()) return;
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
      mesh_.warnings.push_back(std::string(err.what()) + " (opening of #" + std::to_string(element) + " ignored)");
    }
  }
}

/// Append the element and its triangles to the mesh.
void Builder::add_element(BimElement el, const Soup& s, std::vector<Vector3d>& verts) {
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

/// One warning per unsupported entity type, naming its first instance.
void Builder::report_unsupported() {
  for (const auto& [type, info] : unsupported_) {
    mesh_.warnings.push_back(f_.where(info.second) + ": unsupported " + type + " #" + std::to_string(info.second) +
                             (info.first > 1 ? " (and " + std::to_string(info.first - 1) + " more)" : std::string()) +
                             " skipped");
  }
}

/// Metres, origin offset, element bounds.
void Builder::finish(std::vector<Vector3d> verts) {
  const double scale = units_.length_to_m;
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
}

}  // namespace mesh_detail

BimMesh build_mesh(const IfcModel& model, const BimMeshSettings& settings) {
  PLUMB_CHECK(settings.circle_segments >= 3, "build_mesh: circle_segments must be >= 3");
  PLUMB_CHECK(settings.max_depth > 0, "build_mesh: max_depth must be > 0");
  mesh_detail::Builder b(model, settings);
  return b.run();
}

}  // namespace plumb::bim
