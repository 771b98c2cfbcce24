// SPDX-License-Identifier: BSD-3-Clause
// The Builder's 3D geometry: representation items to triangles (extrusions, faces and face sets,
// tessellated face sets, surfaces of linear extrusion, boolean results, mapped items), the choice of
// a product's body representations, and the removal volumes of boolean differences and opening
// elements.
#include "mesh_builder.hpp"

#include <algorithm>
#include <cmath>

#include "plumb/bim/polygon.hpp"

namespace plumb::bim::mesh_detail {

void Builder::add_polygon3(Soup& s, const std::vector<std::vector<Vector3d>>& loops3) {
  if (loops3.empty() || loops3[0].size() < 3) return;
  const auto& o = loops3[0];
  if (loops3.size() == 1 && o.size() == 3) {
    const auto b = static_cast<std::uint32_t>(s.v.size());
    s.v.insert(s.v.end(), o.begin(), o.end());
    s.t.push_back({b, b + 1, b + 2});
    return;
  }
  Vector3d n = Vector3d::Zero();  // Newell normal of the outer loop
  for (std::size_t i = 0; i < o.size(); ++i) {
    const Vector3d& a = o[i];
    const Vector3d& b = o[(i + 1) % o.size()];
    n += Vector3d((a.y() - b.y()) * (a.z() + b.z()), (a.z() - b.z()) * (a.x() + b.x()),
                  (a.x() - b.x()) * (a.y() + b.y()));
  }
  if (!(n.norm() > 0.0)) return;
  n.normalize();
  const Eigen::Matrix3d R = frame_from(n, std::abs(n.x()) < 0.9 ? Vector3d::UnitX() : Vector3d::UnitY());
  std::vector<Loop2> loops2;
  loops2.reserve(loops3.size());
  const auto base = static_cast<std::uint32_t>(s.v.size());
  for (const auto& l : loops3) {
    Loop2 l2;
    l2.reserve(l.size());
    for (const auto& p : l) {
      l2.emplace_back(R.col(0).dot(p), R.col(1).dot(p));
      s.v.push_back(p);
    }
    loops2.push_back(std::move(l2));
  }
  // Triangulation is ccw in (x, y) of the frame, i.e. around +n (the outer loop's own normal).
  for (const Tri& t : triangulate_polygon(loops2)) s.t.push_back({base + t[0], base + t[1], base + t[2]});
}

void Builder::extrusion(std::uint32_t id, Soup& s, int depth) {
  const Args a = args_of(id, 4);
  Profile pr = profile(ref(a[0], id, "SweptArea"), depth + 1);
  const Affine P = axis_placement(a[1], id);
  Vector3d d = direction(ref(a[2], id, "ExtrudedDirection"));
  const double len = num(a[3], id, "Depth");
  if (!(len > 0)) fail(id, "non-positive extrusion depth");
  const Vector3d v = d * len;
  Soup local;
  if (!pr.closed) {
    const auto& l = pr.loops[0];
    for (std::size_t i = 0; i + 1 < l.size(); ++i) {
      const auto b = static_cast<std::uint32_t>(local.v.size());
      const Vector3d p0(l[i].x(), l[i].y(), 0), p1(l[i + 1].x(), l[i + 1].y(), 0);
      local.v.insert(local.v.end(), {p0, p1, p1 + v, p0 + v});
      local.t.push_back({b, b + 1, b + 2});
      local.t.push_back({b, b + 2, b + 3});
    }
    s.append(local, P);
    return;
  }
  // Orientation: outer ccw, holes cw (so sides face outwards for d.z > 0).
  for (std::size_t k = 0; k < pr.loops.size(); ++k) {
    const double area = signed_area(pr.loops[k]);
    if ((k == 0) != (area > 0)) std::reverse(pr.loops[k].begin(), pr.loops[k].end());
  }
  const bool flip = d.z() < 0;
  const auto caps = triangulate_polygon(pr.loops);
  std::uint32_t offset = 0;
  std::vector<std::uint32_t> loop_start;
  for (const auto& l : pr.loops) {
    loop_start.push_back(offset);
    for (const auto& p : l) local.v.emplace_back(p.x(), p.y(), 0.0);
    offset += static_cast<std::uint32_t>(l.size());
  }
  for (std::uint32_t i = 0; i < offset; ++i) local.v.push_back(local.v[i] + v);
  auto tri = [&](std::uint32_t x, std::uint32_t y, std::uint32_t z) {
    if (flip) {
      local.t.push_back({x, z, y});
    } else {
      local.t.push_back({x, y, z});
    }
  };
  for (const Tri& t : caps) {
    tri(t[0], t[2], t[1]);                            // bottom faces -z
    tri(t[0] + offset, t[1] + offset, t[2] + offset);  // top faces +z
  }
  for (std::size_t k = 0; k < pr.loops.size(); ++k) {
    const auto n = static_cast<std::uint32_t>(pr.loops[k].size());
    for (std::uint32_t i = 0; i < n; ++i) {
      const std::uint32_t i0 = loop_start[k] + i, i1 = loop_start[k] + (i + 1) % n;
      tri(i0, i1, i1 + offset);
      tri(i0, i1 + offset, i0 + offset);
    }
  }
  s.append(local, P);
}

void Builder::face(std::uint32_t id, Soup& s) {
  const Args a = args_of(id, 1);
  if (!a[0].is_list()) fail(id, "Bounds must be a list");
  std::vector<std::vector<Vector3d>> loops;
  int outer = -1;
  for (const auto& b : a[0].items) {
    const std::uint32_t bid = ref(b, id, "bound");
    const Args ba = args_of(bid, 2);
    const std::uint32_t lid = ref(ba[0], bid, "Bound");
    if (f_.type_of(lid) != "IFCPOLYLOOP") {
      unsupported(lid);
      continue;
    }
    const Args la = args_of(lid, 1);
    if (!la[0].is_list()) fail(lid, "Polygon must be a list");
    std::vector<Vector3d> loop;
    loop.reserve(la[0].items.size());
    for (const auto& p : la[0].items) loop.push_back(point3(ref(p, lid, "point")));
    if (ba[1].kind == StepValue::Kind::kEnum && ba[1].text == "F") std::reverse(loop.begin(), loop.end());
    if (f_.type_of(bid) == "IFCFACEOUTERBOUND" && outer < 0) outer = static_cast<int>(loops.size());
    loops.push_back(std::move(loop));
  }
  if (loops.empty()) return;
  if (outer > 0) std::swap(loops[0], loops[static_cast<std::size_t>(outer)]);
  add_polygon3(s, loops);
}

void Builder::face_set(std::uint32_t id, Soup& s) {  // IfcClosedShell / IfcOpenShell / IfcConnectedFaceSet
  const Args a = args_of(id, 1);
  if (!a[0].is_list()) fail(id, "CfsFaces must be a list");
  for (const auto& fv : a[0].items) face(ref(fv, id, "face"), s);
}

void Builder::tessellated(std::uint32_t id, Soup& s) {
  const std::string& t = f_.type_of(id);
  const Args a = args_of(id, 3);
  const std::uint32_t cid = ref(a[0], id, "Coordinates");
  const Args ca = args_of(cid, 1);
  if (!ca[0].is_list()) fail(cid, "CoordList must be a list");
  const auto base = static_cast<std::uint32_t>(s.v.size());
  const std::size_t npts = ca[0].items.size();
  for (const auto& c : ca[0].items) {
    if (!c.is_list() || c.items.size() != 3) fail(cid, "bad coordinate");
    s.v.emplace_back(num(c.items[0], cid, "x"), num(c.items[1], cid, "y"), num(c.items[2], cid, "z"));
  }
  if (t == "IFCTRIANGULATEDFACESET" || t == "IFCTRIANGULATEDIRREGULARNETWORK") {
    if (a.size() < 4 || !a[3].is_list()) fail(id, "CoordIndex must be a list");
    const StepValue* pn = a.size() >= 5 && a[4].is_list() ? &a[4] : nullptr;
    auto index = [&](const StepValue& v) -> std::uint32_t {
      double k = v.number();
      if (pn) {
        if (!(k >= 1 && k <= static_cast<double>(pn->items.size()))) fail(id, "PnIndex out of range");
        k = pn->items[static_cast<std::size_t>(k) - 1].number();
      }
      if (!(k >= 1 && k <= static_cast<double>(npts))) fail(id, "coordinate index out of range");
      return base + static_cast<std::uint32_t>(k) - 1;
    };
    for (const auto& tri : a[3].items) {
      if (!tri.is_list() || tri.items.size() != 3) fail(id, "triangle needs 3 indices");
      s.t.push_back({index(tri.items[0]), index(tri.items[1]), index(tri.items[2])});
    }
  } else {  // IFCPOLYGONALFACESET(Coordinates, Closed, Faces, PnIndex)
    if (!a[2].is_list()) fail(id, "Faces must be a list");
    const StepValue* pn = a.size() >= 4 && a[3].is_list() ? &a[3] : nullptr;
    auto pt = [&](const StepValue& v) -> Vector3d {
      double k = v.number();
      if (pn) {
        if (!(k >= 1 && k <= static_cast<double>(pn->items.size()))) fail(id, "PnIndex out of range");
        k = pn->items[static_cast<std::size_t>(k) - 1].number();
      }
      if (!(k >= 1 && k <= static_cast<double>(npts))) fail(id, "coordinate index out of range");
      return s.v[base + static_cast<std::uint32_t>(k) - 1];
    };
    for (const auto& fv : a[2].items) {
      const std::uint32_t fid = ref(fv, id, "face");
      const Args fa = args_of(fid, 1);
      std::vector<std::vector<Vector3d>> loops(1);
      if (!fa[0].is_list()) fail(fid, "CoordIndex must be a list");
      for (const auto& k : fa[0].items) loops[0].push_back(pt(k));
      if (fa.size() >= 2 && fa[1].is_list()) {
        for (const auto& inner : fa[1].items) {
          if (!inner.is_list()) continue;
          loops.emplace_back();
          for (const auto& k : inner.items) loops.back().push_back(pt(k));
        }
      }
      add_polygon3(s, loops);
    }
  }
}

/// A half-space or solid operand as a removal volume in item coordinates.
Volume Builder::volume(std::uint32_t id, int depth) {
  check_depth(id, depth);
  const std::string& t = f_.type_of(id);
  Volume vol;
  if (t == "IFCHALFSPACESOLID" || t == "IFCPOLYGONALBOUNDEDHALFSPACE" || t == "IFCBOXEDHALFSPACE") {
    const Args a = args_of(id, 2);
    const std::uint32_t sid = ref(a[0], id, "BaseSurface");
    if (f_.type_of(sid) != "IFCPLANE") {
      unsupported(sid);
      fail(id, "base surface is not an IfcPlane");
    }
    const Args pa = args_of(sid, 1);
    const Affine Pp = axis_placement(pa[0], sid);
    // AgreementFlag TRUE: the plane normal points away from the half-space material.
    const bool agree = !(a[1].kind == StepValue::Kind::kEnum && a[1].text == "F");
    Vector3d n = Pp.linear().col(2);
    double d = -n.dot(Pp.translation());
    if (!agree) {
      n = -n;
      d = -d;
    }
    // Material (inside) is n.x + d < 0 in item coordinates.
    if (t == "IFCPOLYGONALBOUNDEDHALFSPACE" && a.size() >= 4) {
      const Affine Pos = axis_placement(a[2], id);
      Loop2 boundary;
      curve(ref(a[3], id, "PolygonalBoundary"), boundary, depth + 1);
      close_loop(boundary);
      if (boundary.size() < 3) fail(id, "boundary has fewer than 3 points");
      vol.to_local = Pos.inverse();
      vol.has_prism = true;
      vol.loops.push_back(boundary);
      vol.dir = Vector3d::UnitZ();
    }
    // Express the plane in the local frame: x = L^{-1} p.
    const Affine from_local = vol.to_local.inverse();
    vol.has_hs = true;
    vol.hs_n = from_local.linear().transpose() * n;
    vol.hs_d = n.dot(from_local.translation()) + d;
    const double nn = vol.hs_n.norm();
    vol.hs_n /= nn;
    vol.hs_d /= nn;
  } else if (t == "IFCEXTRUDEDAREASOLID") {
    const Args a = args_of(id, 4);
    Profile pr = profile(ref(a[0], id, "SweptArea"), depth + 1);
    if (!pr.closed) fail(id, "open profile cannot bound a volume");
    Vector3d d = direction(ref(a[2], id, "ExtrudedDirection"));
    const double len = num(a[3], id, "Depth");
    if (std::abs(d.z()) < 1e-9) fail(id, "extrusion direction parallel to the profile plane");
    vol.to_local = axis_placement(a[1], id).inverse();
    vol.has_prism = true;
    vol.loops = pr.loops;
    if (d.z() < 0) {
      vol.dir = -d;
      vol.z_lo = d.z() * len;
      vol.z_hi = 0.0;
    } else {
      vol.dir = d;
      vol.z_lo = 0.0;
      vol.z_hi = d.z() * len;
    }
  } else {
    // Any other solid: its axis-aligned box (openings are nearly always boxes).
    Soup s;
    item(id, s, depth + 1);
    if (s.v.empty()) fail(id, "operand has no geometry");
    Vector3d lo = Vector3d::Constant(kInf), hi = -lo;
    for (const auto& p : s.v) {
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
    vol.has_prism = true;
    vol.loops.push_back({{lo.x(), lo.y()}, {hi.x(), lo.y()}, {hi.x(), hi.y()}, {lo.x(), hi.y()}});
    vol.z_lo = lo.z();
    vol.z_hi = hi.z();
  }
  return vol;
}

void Builder::boolean_result(std::uint32_t id, Soup& s, int depth) {
  const Args a = args_of(id, 3);
  const std::string op = a[0].text;
  Soup first;
  item(ref(a[1], id, "FirstOperand"), first, depth + 1);
  const std::uint32_t second = ref(a[2], id, "SecondOperand");
  if (op == "UNION") {
    item(second, first, depth + 1);
  } else if (op == "DIFFERENCE") {
    const Volume vol = volume(second, depth + 1);
    const Soup cut = reveal_faces(first, vol, eps_);
    subtract_volume(first, vol, eps_);
    first.append(cut, Affine::Identity());
  } else {
    unsupported(id);  // INTERSECTION: keep the first operand
  }
  s.append(first, Affine::Identity());
}

void Builder::mapped_item(std::uint32_t id, Soup& s, int depth) {
  const Args a = args_of(id, 2);
  const std::uint32_t map = ref(a[0], id, "MappingSource");
  const Args ma = args_of(map, 2);
  const Affine origin = [&]() {
    if (ma[0].is_ref() && f_.type_of(ma[0].ref).rfind("IFCCARTESIANTRANSFORMATIONOPERATOR", 0) == 0) {
      return transformation_operator(ma[0].ref);
    }
    return axis_placement(ma[0], map);
  }();
  const Affine target = transformation_operator(ref(a[1], id, "MappingTarget"));
  Soup local;
  representation_items(ref(ma[1], map, "MappedRepresentation"), local, depth + 1);
  s.append(local, target * origin);
}

void Builder::representation_items(std::uint32_t rep, Soup& s, int depth) {
  check_depth(rep, depth);
  const Args a = args_of(rep, 4);
  if (!a[3].is_list()) fail(rep, "Items must be a list");
  for (const auto& it : a[3].items) item(ref(it, rep, "item"), s, depth + 1);
}

/// Geometry of one representation item in its own coordinates, appended to s.
void Builder::item(std::uint32_t id, Soup& s, int depth) {
  check_depth(id, depth);
  const std::string& t = f_.type_of(id);
  if (t == "IFCEXTRUDEDAREASOLID") {
    extrusion(id, s, depth);
  } else if (t == "IFCFACETEDBREP" || t == "IFCFACETEDBREPWITHVOIDS") {
    const Args a = args_of(id, 1);
    face_set(ref(a[0], id, "Outer"), s);
  } else if (t == "IFCCLOSEDSHELL" || t == "IFCOPENSHELL" || t == "IFCCONNECTEDFACESET") {
    face_set(id, s);
  } else if (t == "IFCFACEBASEDSURFACEMODEL" || t == "IFCSHELLBASEDSURFACEMODEL") {
    const Args a = args_of(id, 1);
    if (!a[0].is_list()) fail(id, "expects a list");
    for (const auto& sh : a[0].items) face_set(ref(sh, id, "shell"), s);
  } else if (t == "IFCTRIANGULATEDFACESET" || t == "IFCPOLYGONALFACESET" || t == "IFCTRIANGULATEDIRREGULARNETWORK") {
    tessellated(id, s);
  } else if (t == "IFCMAPPEDITEM") {
    mapped_item(id, s, depth);
  } else if (t == "IFCBOOLEANCLIPPINGRESULT" || t == "IFCBOOLEANRESULT") {
    boolean_result(id, s, depth);
  } else if (t == "IFCSURFACEOFLINEAREXTRUSION") {
    const Args a = args_of(id, 4);
    Profile pr = profile(ref(a[0], id, "SweptCurve"), depth + 1);
    const Affine P = axis_placement(a[1], id);
    const Vector3d v = direction(ref(a[2], id, "ExtrudedDirection")) * num(a[3], id, "Depth");
    Soup local;
    for (const auto& l : pr.loops) {
      const std::size_t m = pr.closed ? l.size() : l.size() - 1;
      for (std::size_t i = 0; i < m && l.size() >= 2; ++i) {
        const auto b = static_cast<std::uint32_t>(local.v.size());
        const Vector3d p0(l[i].x(), l[i].y(), 0), p1(l[(i + 1) % l.size()].x(), l[(i + 1) % l.size()].y(), 0);
        local.v.insert(local.v.end(), {p0, p1, p1 + v, p0 + v});
        local.t.push_back({b, b + 1, b + 2});
        local.t.push_back({b, b + 2, b + 3});
      }
    }
    s.append(local, P);
  } else if (t == "IFCFACE") {
    face(id, s);
  } else if (t == "IFCSTYLEDITEM" || t == "IFCBOUNDINGBOX" || t == "IFCGEOMETRICCURVESET" ||
             t == "IFCGEOMETRICSET" || t == "IFCANNOTATIONFILLAREA" || t == "IFCTEXTLITERAL" ||
             t == "IFCPOLYLINE" || t == "IFCCARTESIANPOINT") {
    // Not surface geometry: ignored.
  } else {
    unsupported(id);
  }
}

/// Body representations of a product definition shape (Body, else Facetation, else solid types).
std::vector<std::uint32_t> Builder::body_representations(std::uint32_t pds) {
  std::vector<std::uint32_t> body, facet, other;
  if (f_.type_of(pds) != "IFCPRODUCTDEFINITIONSHAPE" && f_.type_of(pds) != "IFCPRODUCTREPRESENTATION") return body;
  const Args a = args_of(pds, 3);
  if (!a[2].is_list()) fail(pds, "Representations must be a list");
  for (const auto& r : a[2].items) {
    const std::uint32_t rid = ref(r, pds, "representation");
    if (f_.type_of(rid) != "IFCSHAPEREPRESENTATION") continue;
    const Args ra = args_of(rid, 4);
    const std::string ident = ra[1].kind == StepValue::Kind::kString ? ra[1].text : "";
    const std::string type = ra[2].kind == StepValue::Kind::kString ? ra[2].text : "";
    if (ident == "Body") {
      body.push_back(rid);
    } else if (ident == "Facetation") {
      facet.push_back(rid);
    } else if (ident.empty() && (type == "SweptSolid" || type == "Brep" || type == "SurfaceModel" ||
                                 type == "Tessellation" || type == "Clipping" || type == "CSG" ||
                                 type == "MappedRepresentation" || type == "SolidModel")) {
      other.push_back(rid);
    }
  }
  if (!body.empty()) return body;
  if (!facet.empty()) return facet;
  return other;
}

/// Opening volumes of an opening element in world (file-unit) coordinates.
void Builder::opening_volumes(std::uint32_t opening, std::vector<Volume>& out) {
  const Args a = args_of(opening, 7);
  const Affine T = a[5].is_null() ? Affine::Identity() : local_placement(ref(a[5], opening, "ObjectPlacement"), 0);
  if (a[6].is_null()) return;
  for (std::uint32_t rep : body_representations(ref(a[6], opening, "Representation"))) {
    const Args ra = args_of(rep, 4);
    if (!ra[3].is_list()) continue;
    for (const auto& it : ra[3].items) collect_volumes(ref(it, rep, "item"), T, out, 1);
  }
}

void Builder::collect_volumes(std::uint32_t id, const Affine& T, std::vector<Volume>& out, int depth) {
  check_depth(id, depth);
  const std::string& t = f_.type_of(id);
  if (t == "IFCMAPPEDITEM") {
    const Args a = args_of(id, 2);
    const std::uint32_t map = ref(a[0], id, "MappingSource");
    const Args ma = args_of(map, 2);
    const Affine M = T * transformation_operator(ref(a[1], id, "MappingTarget")) * axis_placement(ma[0], map);
    const Args ra = args_of(ref(ma[1], map, "MappedRepresentation"), 4);
    if (!ra[3].is_list()) return;
    for (const auto& it : ra[3].items) collect_volumes(ref(it, ma[1].ref, "item"), M, out, depth + 1);
  } else if (t == "IFCBOOLEANCLIPPINGRESULT" || t == "IFCBOOLEANRESULT") {
    const Args a = args_of(id, 3);
    collect_volumes(ref(a[1], id, "FirstOperand"), T, out, depth + 1);
  } else if (t == "IFCSTYLEDITEM" || t == "IFCBOUNDINGBOX") {
  } else {
    Volume v = volume(id, depth + 1);
    v.apply(T);
    out.push_back(std::move(v));
  }
}

}  // namespace plumb::bim::mesh_detail
