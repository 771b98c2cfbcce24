// SPDX-License-Identifier: BSD-3-Clause
// The building model: IFC -> labelled triangle mesh (bim::BimMesh) and the clouds sampled from it.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <pybind11/eigen.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include "convert.hpp"
#include "plumb/bim/bim_cloud.hpp"
#include "plumb/bim/ifc.hpp"
#include "plumb/bim/mesh.hpp"
#include "plumb/bim/sample.hpp"

namespace plumb::python {
namespace {

void bind_mesh_types(py::module_& m) {
  using bim::BimElement;
  using bim::BimMesh;
  using bim::BimStorey;
  py::class_<bim::BimMeshSettings>(m, "BimMeshSettings", "How read_ifc() meshes the model (bim::BimMeshSettings).")
      .def(py::init<>())
      .def_readwrite("subtract_openings", &bim::BimMeshSettings::subtract_openings)
      .def_readwrite("include_spaces", &bim::BimMeshSettings::include_spaces)
      .def_readwrite("offset_threshold", &bim::BimMeshSettings::offset_threshold)
      .def_readwrite("offset_rounding", &bim::BimMeshSettings::offset_rounding)
      .def_readwrite("circle_segments", &bim::BimMeshSettings::circle_segments)
      .def_readwrite("max_depth", &bim::BimMeshSettings::max_depth);
  py::class_<BimStorey>(m, "BimStorey", "A building storey (IfcBuildingStorey).")
      .def_readonly("express_id", &BimStorey::express_id)
      .def_readonly("name", &BimStorey::name)
      .def_readonly("elevation", &BimStorey::elevation);
  py::class_<BimElement>(m, "BimElement", "One IFC product and its triangles [first_triangle, +num_triangles).")
      .def_readonly("express_id", &BimElement::express_id)
      .def_readonly("global_id", &BimElement::global_id)
      .def_readonly("type", &BimElement::type)
      .def_readonly("name", &BimElement::name)
      .def_readonly("storey", &BimElement::storey)
      .def_readonly("first_triangle", &BimElement::first_triangle)
      .def_readonly("num_triangles", &BimElement::num_triangles)
      .def_readonly("bbox_min", &BimElement::bbox_min)
      .def_readonly("bbox_max", &BimElement::bbox_max)
      .def_readonly("has_body", &BimElement::has_body);
  py::class_<BimMesh>(m, "BimMesh",
                      "Triangle mesh of a building, each triangle tagged with its element. vertices (V, 3) float64 "
                      "[m], triangles (T, 3) uint32, triangle_element (T,) int32 (index into elements).")
      .def_property_readonly("vertices",
                             [](const BimMesh& b) {
                               return table_to_array(b.vertices, 3, [](const Vector3d& v, double* row) {
                                 for (int a = 0; a < 3; ++a) row[a] = v[a];
                               });
                             })
      .def_property_readonly("triangles",
                             [](const BimMesh& b) {
                               py::array_t<std::uint32_t> out(
                                   {static_cast<py::ssize_t>(b.triangles.size()), py::ssize_t{3}});
                               std::uint32_t* dst = out.mutable_data();
                               for (std::size_t i = 0; i < b.triangles.size(); ++i) {
                                 for (std::size_t a = 0; a < 3; ++a) dst[3 * i + a] = b.triangles[i][a];
                               }
                               return out;
                             })
      .def_property_readonly("triangle_element", [](const BimMesh& b) { return vector_to_array(b.triangle_element); })
      .def_readonly("elements", &BimMesh::elements)
      .def_readonly("storeys", &BimMesh::storeys)
      .def_readonly("origin_offset", &BimMesh::origin_offset)
      .def_readonly("warnings", &BimMesh::warnings)
      .def("num_triangles", &BimMesh::num_triangles)
      .def(
          "bounds",
          [](const BimMesh& b) {
            Vector3d lo, hi;
            b.bounds(lo, hi);
            return py::make_tuple(lo, hi);
          },
          "(lo, hi): axis-aligned bounds of all vertices.")
      .def("find_element", &BimMesh::find_element, py::arg("express_id"), "Index of an element, -1 if absent.");
}

}  // namespace

void bind_bim(py::module_& m) {
  bind_mesh_types(m);
  m.def(
      "read_ifc",
      [](const std::filesystem::path& path, const py::kwargs& kwargs) {
        auto settings = settings_from_kwargs<bim::BimMeshSettings>(kwargs, "read_ifc");
        // The rooms belong to a building a robot drives in (bim::mesh_settings_with_spaces(), as the CLI).
        if (!kwargs.contains("settings") && !kwargs.contains("include_spaces")) {
          settings.include_spaces = bim::mesh_settings_with_spaces().include_spaces;
        }
        py::gil_scoped_release release;
        return bim::build_mesh(bim::read_ifc(path.string()), settings);
      },
      py::arg("path"),
      "Read an IFC file (STEP) and mesh it: bim::read_ifc then bim::build_mesh. Keyword arguments: the fields of "
      "BimMeshSettings; include_spaces is True unless given (rooms are meshed, as `plumb run` does).");
  m.def(
      "sample_bim_cloud",
      [](const bim::BimMesh& mesh, double spacing) {
        py::gil_scoped_release release;
        return bim::sample_bim_cloud(mesh, spacing);
      },
      py::arg("mesh"), py::arg("spacing") = 0.05,
      "The BIM cloud a LiDAR is registered to: the surfaces a LiDAR sees sampled every `spacing` metres, with "
      "face normals and element labels.");
  m.def(
      "sample_surface",
      [](const bim::BimMesh& mesh, double spacing, std::uint64_t seed, const std::vector<std::string>& types,
         int storey) {
        bim::SurfaceSampleSettings s;
        s.spacing = spacing;
        s.seed = seed;
        s.filter.types = types;
        s.filter.storey = storey;
        py::gil_scoped_release release;
        return bim::sample_surface(mesh, s);
      },
      py::arg("mesh"), py::arg("spacing") = bim::SurfaceSampleSettings{}.spacing,
      py::arg("seed") = bim::SurfaceSampleSettings{}.seed, py::arg("types") = std::vector<std::string>{},
      py::arg("storey") = -1,
      "Area-uniform random points on the mesh (every element, or those of `types` / `storey`), with normals and "
      "element labels.");
}

}  // namespace plumb::python
