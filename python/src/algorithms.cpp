// SPDX-License-Identifier: BSD-3-Clause
// Filters, search and features: voxel_grid, KdTree, estimate_normals.
#include <algorithm>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>

#include <pybind11/eigen.h>

#include "convert.hpp"
#include "plumb/features/normals.hpp"
#include "plumb/filters/voxel_grid.hpp"
#include "plumb/search/kdtree.hpp"

namespace plumb::python {
namespace {

/// A KdTree3f with the points it was built from (estimate_normals() needs both).
struct PyKdTree {
  std::vector<Vector3f> points;
  std::unique_ptr<KdTree3f> tree;
};

void bind_voxel_grid(py::module_& m) {
  py::enum_<VoxelMode>(m, "VoxelMode", "What a voxel of voxel_grid() keeps.")
      .value("nearest_to_centroid", VoxelMode::kNearestToCentroid)
      .value("centroid", VoxelMode::kCentroid);
  py::class_<VoxelGridSettings>(m, "VoxelGridSettings", "Settings of voxel_grid().")
      .def(py::init<>())
      .def_readwrite("leaf_size", &VoxelGridSettings::leaf_size)
      .def_readwrite("mode", &VoxelGridSettings::mode)
      .def_readwrite("min_points_per_voxel", &VoxelGridSettings::min_points_per_voxel);
  py::class_<VoxelGridResult>(m, "VoxelGridResult", "Result of voxel_grid().")
      .def_readonly("cloud", &VoxelGridResult::cloud)
      .def_property_readonly("indices", [](const VoxelGridResult& r) { return indices_to_array(r.indices); })
      .def_readonly("num_voxels", &VoxelGridResult::num_voxels)
      .def_readonly("num_sparse_voxels", &VoxelGridResult::num_sparse_voxels)
      .def_readonly("num_dropped_non_finite", &VoxelGridResult::num_dropped_non_finite)
      .def_readonly("status", &VoxelGridResult::status);

  m.def(
      "voxel_grid",
      [](const py::object& cloud, const py::kwargs& kwargs) {
        const auto settings = settings_from_kwargs<VoxelGridSettings>(kwargs, "voxel_grid");
        const PointCloud c = cloud_from_object(cloud, "voxel_grid: cloud");
        py::gil_scoped_release release;
        return voxel_grid(c, settings);
      },
      py::arg("cloud"),
      "Downsample a PointCloud (or an (N, 3) point array) to one point per voxel. Keyword arguments: the fields "
      "of VoxelGridSettings (leaf_size, mode, min_points_per_voxel).");
}

/// One query row per point of `queries` ((M, 3) or a single (3,) point).
std::vector<Vector3f> queries_from_array(const py::handle& obj, bool& single) {
  const py::array arr = py::array::ensure(obj);
  single = arr && arr.ndim() == 1;
  if (single) return {point_from_array(obj, "KdTree.knn: queries")};
  return points_from_array(obj, "KdTree.knn: queries");
}

py::tuple kdtree_knn(const PyKdTree& self, const py::object& queries, std::size_t k) {
  bool single = false;
  const std::vector<Vector3f> q = queries_from_array(queries, single);
  const std::size_t cols = std::min(k, self.tree->size());
  const auto rows = static_cast<py::ssize_t>(q.size());
  py::array_t<std::int64_t> indices({rows, static_cast<py::ssize_t>(cols)});
  py::array_t<float> sq_dists({rows, static_cast<py::ssize_t>(cols)});
  std::int64_t* idx = indices.mutable_data();
  float* dst = sq_dists.mutable_data();
  {
    py::gil_scoped_release release;
    std::vector<std::size_t> found(cols);
    std::vector<float> d(cols);
    for (std::size_t i = 0; i < q.size(); ++i) {
      const std::size_t n = self.tree->knn(q[i], cols, found.data(), d.data());
      for (std::size_t j = 0; j < cols; ++j) {
        idx[i * cols + j] = j < n ? static_cast<std::int64_t>(found[j]) : -1;
        dst[i * cols + j] = j < n ? d[j] : std::numeric_limits<float>::infinity();
      }
    }
  }
  if (single) return py::make_tuple(indices.attr("reshape")(cols), sq_dists.attr("reshape")(cols));
  return py::make_tuple(indices, sq_dists);
}

void bind_kdtree(py::module_& m) {
  py::enum_<KdTreeSplit>(m, "KdTreeSplit", "Where a KdTree node is cut along its widest dimension.")
      .value("mean", KdTreeSplit::kMean)
      .value("midpoint", KdTreeSplit::kMidpoint);
  py::class_<PyKdTree>(m, "KdTree",
                       "Static kd-tree over (N, 3) points for exact k-nearest and radius queries. Indices refer to "
                       "the rows of the points it was built from; non-finite points are skipped.")
      .def(py::init([](const py::object& points, std::size_t leaf_size, KdTreeSplit split) {
             auto self = std::make_unique<PyKdTree>();
             self->points = points_from_array(points, "KdTree: points");
             py::gil_scoped_release release;
             self->tree = std::make_unique<KdTree3f>(self->points, KdTreeSettings{leaf_size, split});
             return self;
           }),
           py::arg("points"), py::arg("leaf_size") = KdTreeSettings{}.leaf_size,
           py::arg("split") = KdTreeSettings{}.split)
      .def("size", [](const PyKdTree& t) { return t.tree->size(); }, "Number of indexed (finite) points.")
      .def("__len__", [](const PyKdTree& t) { return t.tree->size(); })
      .def("num_skipped", [](const PyKdTree& t) { return t.tree->num_skipped(); })
      .def_property_readonly("points", [](const PyKdTree& t) { return points_to_array(t.points); })
      .def("knn", &kdtree_knn, py::arg("queries"), py::arg("k"),
           "The k nearest points of each query ((M, 3), or one (3,) point), sorted by distance: (indices int64, "
           "squared distances float32), each (M, min(k, size())) (or 1-D for one point). A non-finite query's "
           "row is -1 / inf.")
      .def(
          "radius",
          [](const PyKdTree& t, const py::object& query, float r, bool sorted) {
            const Vector3f q = point_from_array(query, "KdTree.radius: query");
            std::vector<std::size_t> indices;
            std::vector<float> sq_dists;
            {
              py::gil_scoped_release release;
              t.tree->radius(q, r, indices, sq_dists, sorted);
            }
            return py::make_tuple(indices_to_array(indices), vector_to_array(sq_dists));
          },
          py::arg("query"), py::arg("r"), py::arg("sorted") = true,
          "All points within distance r [m] of one (3,) query: (indices int64, squared distances float32).")
      .def(
          "nearest",
          [](const PyKdTree& t, const py::object& query, float max_dist_sq) -> py::object {
            const std::optional<Neighbor> n = t.tree->nearest(point_from_array(query, "KdTree.nearest: query"),
                                                              max_dist_sq);
            if (!n) return py::none();
            return py::make_tuple(static_cast<std::int64_t>(n->index), n->dist_sq);
          },
          py::arg("query"), py::arg("max_dist_sq") = std::numeric_limits<float>::infinity(),
          "(index, squared distance) of the nearest point within max_dist_sq, or None.");
}

void bind_normals(py::module_& m) {
  py::class_<NormalSettings>(m, "NormalSettings", "Neighbourhood and orientation of estimate_normals().")
      .def(py::init<>())
      .def_readwrite("k", &NormalSettings::k)
      .def_readwrite("radius", &NormalSettings::radius)
      .def_readwrite("viewpoint", &NormalSettings::viewpoint)
      .def_readwrite("orient_to_viewpoint", &NormalSettings::orient_to_viewpoint)
      .def_readwrite("threads", &NormalSettings::threads);
  py::class_<NormalResult>(m, "NormalResult", "Per-point normals and surface variation.")
      .def_property_readonly("normals", [](const NormalResult& r) { return points_to_array(r.normals); })
      .def_property_readonly("curvature", [](const NormalResult& r) { return vector_to_array(r.curvature); })
      .def_readonly("num_invalid", &NormalResult::num_invalid);

  m.def(
      "estimate_normals",
      [](const py::object& points, const PyKdTree* tree, const py::kwargs& kwargs) {
        const auto settings = settings_from_kwargs<NormalSettings>(kwargs, "estimate_normals");
        const std::vector<Vector3f> cloud = points_from_array(points, "estimate_normals: points");
        py::gil_scoped_release release;
        if (tree != nullptr) return estimate_normals(cloud, *tree->tree, tree->points, settings);
        const KdTree3f own(cloud);
        return estimate_normals(cloud, own, cloud, settings);
      },
      py::arg("points"), py::arg("tree") = nullptr,
      "Normal of every point by PCA of its neighbours in `tree` (a KdTree; by default one built on `points`). "
      "Keyword arguments: the fields of NormalSettings (k, radius, viewpoint, orient_to_viewpoint).");
}

}  // namespace

void bind_algorithms(py::module_& m) {
  bind_voxel_grid(m);
  bind_kdtree(m);
  bind_normals(m);
}

}  // namespace plumb::python
