// SPDX-License-Identifier: BSD-3-Clause
// FPFH descriptors, SAC-IA global registration and the segmentation of a LiDAR frame.
#include <cstdint>
#include <cstring>
#include <vector>

#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include "convert.hpp"
#include "plumb/features/fpfh.hpp"
#include "plumb/registration/sac_ia.hpp"
#include "plumb/search/kdtree.hpp"
#include "plumb/segmentation/segment_frame.hpp"

namespace plumb::python {
namespace {

py::array_t<float> signatures_to_array(const std::vector<FpfhSignature>& features) {
  py::array_t<float> out({static_cast<py::ssize_t>(features.size()), py::ssize_t{kFpfhBins}});
  if (!features.empty()) std::memcpy(out.mutable_data(), features.data(), features.size() * sizeof(FpfhSignature));
  return out;
}

std::vector<FpfhSignature> signatures_from_array(const py::handle& obj, const char* what) {
  const auto table = table_from_array(obj, what, kFpfhBins);
  std::vector<FpfhSignature> out(static_cast<std::size_t>(table.shape(0)));
  for (std::size_t i = 0; i < out.size(); ++i) {
    for (std::size_t j = 0; j < static_cast<std::size_t>(kFpfhBins); ++j) {
      out[i][j] = static_cast<float>(table.data()[i * kFpfhBins + j]);
    }
  }
  return out;
}

void bind_fpfh(py::module_& m) {
  py::class_<FpfhSettings>(m, "FpfhSettings", "Settings of compute_fpfh().")
      .def(py::init<>())
      .def_readwrite("radius", &FpfhSettings::radius)
      .def_readwrite("max_neighbors", &FpfhSettings::max_neighbors)
      .def_readwrite("visible_side_tolerance", &FpfhSettings::visible_side_tolerance)
      .def_readwrite("threads", &FpfhSettings::threads);
  py::class_<FpfhResult>(m, "FpfhResult", "FPFH signatures: features (M, 33) float32, indices (M,) int64.")
      .def_property_readonly("features", [](const FpfhResult& r) { return signatures_to_array(r.features); })
      .def_property_readonly("indices", [](const FpfhResult& r) { return indices_to_array(r.indices); })
      .def_readonly("num_invalid", &FpfhResult::num_invalid);
  m.def(
      "compute_fpfh",
      [](const PointCloud& cloud, const py::object& indices, const py::kwargs& kwargs) {
        const auto settings = settings_from_kwargs<FpfhSettings>(kwargs, "compute_fpfh");
        std::vector<std::size_t> idx;
        if (!indices.is_none()) {
          for (const std::int64_t i : ints_from_array<std::int64_t>(indices, "compute_fpfh: indices")) {
            if (i < 0) throw py::value_error("compute_fpfh: indices must be >= 0");
            idx.push_back(static_cast<std::size_t>(i));
          }
        }
        py::gil_scoped_release release;
        return compute_fpfh(cloud, settings, indices.is_none() ? nullptr : &idx);
      },
      py::arg("cloud"), py::arg("indices") = py::none(),
      "Fast Point Feature Histograms (Rusu 2009) of every point of a PointCloud with normals, or of the points "
      "`indices`. Keyword arguments: the fields of FpfhSettings (radius, max_neighbors, visible_side_tolerance, threads).");
}

void bind_sac_ia(py::module_& m) {
  py::class_<SacIaSettings>(m, "SacIaSettings", "Settings of align_sac_ia() (the C++ defaults).")
      .def(py::init<>())
      .def_readwrite("num_samples", &SacIaSettings::num_samples)
      .def_readwrite("min_sample_distance", &SacIaSettings::min_sample_distance)
      .def_readwrite("k_correspondences", &SacIaSettings::k_correspondences)
      .def_readwrite("similarity_weighted", &SacIaSettings::similarity_weighted)
      .def_readwrite("max_iterations", &SacIaSettings::max_iterations)
      .def_readwrite("huber_threshold", &SacIaSettings::huber_threshold)
      .def_readwrite("max_correspondence_distance", &SacIaSettings::max_correspondence_distance)
      .def_readwrite("edge_similarity", &SacIaSettings::edge_similarity)
      .def_readwrite("confidence", &SacIaSettings::confidence)
      .def_readwrite("mutual_filter", &SacIaSettings::mutual_filter)
      .def_readwrite("num_prescore_points", &SacIaSettings::num_prescore_points)
      .def_readwrite("prescore_slack", &SacIaSettings::prescore_slack)
      .def_readwrite("seed", &SacIaSettings::seed)
      .def_readwrite("region_center", &SacIaSettings::region_center)
      .def_readwrite("region_radius", &SacIaSettings::region_radius);
  py::class_<SacIaResult> r(m, "SacIaResult", "Result of align_sac_ia(); T_target_source is a 4x4 float64 array.");
  r.def_readonly("status", &SacIaResult::status)
      .def_readonly("converged", &SacIaResult::converged)
      .def_readonly("iterations", &SacIaResult::iterations)
      .def_readonly("num_scored", &SacIaResult::num_scored)
      .def_readonly("num_fully_scored", &SacIaResult::num_fully_scored)
      .def_readonly("num_inliers", &SacIaResult::num_inliers)
      .def_readonly("overlap", &SacIaResult::overlap)
      .def_readonly("rmse", &SacIaResult::rmse)
      .def_readonly("score", &SacIaResult::score);
  def_pose(r, "T_target_source", &SacIaResult::T_target_source);
  m.def(
      "align_sac_ia",
      [](const py::object& source, const py::object& source_features, const py::object& target,
         const py::object& target_features, const py::kwargs& kwargs) {
        const auto settings = settings_from_kwargs<SacIaSettings>(kwargs, "align_sac_ia");
        const PointCloud s = cloud_from_object(source, "align_sac_ia: source");
        const PointCloud t = cloud_from_object(target, "align_sac_ia: target");
        const auto fs = signatures_from_array(source_features, "align_sac_ia: source_features");
        const auto ft = signatures_from_array(target_features, "align_sac_ia: target_features");
        py::gil_scoped_release release;
        const KdTree3f tree(t.points);
        return align_sac_ia(s, fs, t, ft, tree, settings);
      },
      py::arg("source"), py::arg("source_features"), py::arg("target"), py::arg("target_features"),
      "Sample-consensus initial alignment (Liu et al. 2022, sec. 1.2) of `source` to `target` from their FPFH "
      "features ((N, 33) arrays parallel to the points; compute_fpfh().features). Keyword arguments: the fields of "
      "SacIaSettings.");
}

void bind_segmentation(py::module_& m) {
  py::class_<FrameSampleSettings>(m, "FrameSampleSettings", "Voxel sample and normals of segment_frame().")
      .def(py::init<>())
      .def_readwrite("voxel_size", &FrameSampleSettings::voxel_size)
      .def_readwrite("normal_k", &FrameSampleSettings::normal_k);
  py::class_<GroundSettings>(m, "GroundSettings", "Ground step of segment_frame().")
      .def(py::init<>())
      .def_readwrite("sensor_height", &GroundSettings::sensor_height)
      .def_readwrite("min_plane_fraction", &GroundSettings::min_plane_fraction);
  py::class_<VerticalPlaneSettings>(m, "VerticalPlaneSettings", "Vertical-plane step of segment_frame().")
      .def(py::init<>())
      .def_readwrite("max_normal_angle", &VerticalPlaneSettings::max_normal_angle);
  py::class_<SegmentSettings>(m, "SegmentSettings", "Settings of segment_frame(): sample, ground, vertical.")
      .def(py::init<>())
      .def_readwrite("sample", &SegmentSettings::sample)
      .def_readwrite("ground", &SegmentSettings::ground)
      .def_readwrite("vertical", &SegmentSettings::vertical);
  py::class_<SegmentResult>(m, "SegmentResult",
                            "labels: (N,) int32, 0 other, 1 ground, 2 vertical (SEGMENT_OTHER, SEGMENT_GROUND, "
                            "SEGMENT_VERTICAL); ground_inliers: input indices of the ground plane.")
      .def_property_readonly("labels", [](const SegmentResult& r) { return vector_to_array(r.labels); })
      .def_readonly("status", &SegmentResult::status)
      .def_property_readonly("ground_inliers", [](const SegmentResult& r) { return indices_to_array(r.ground.inliers); })
      .def_readonly("num_ground", &SegmentResult::num_ground)
      .def_readonly("num_vertical", &SegmentResult::num_vertical)
      .def_readonly("num_other", &SegmentResult::num_other)
      .def_readonly("num_sample", &SegmentResult::num_sample);
  m.attr("SEGMENT_OTHER") = kSegmentOther;
  m.attr("SEGMENT_GROUND") = kSegmentGround;
  m.attr("SEGMENT_VERTICAL") = kSegmentVertical;
  m.def(
      "segment_frame",
      [](const py::object& cloud, const py::kwargs& kwargs) {
        const auto settings = settings_from_kwargs<SegmentSettings>(kwargs, "segment_frame");
        const PointCloud c = cloud_from_object(cloud, "segment_frame: cloud");
        py::gil_scoped_release release;
        return segment_frame(c, settings);
      },
      py::arg("cloud"),
      "Ground, vertical-plane key points and the rest of one LiDAR frame (sensor frame, z up). Keyword arguments: "
      "the fields of SegmentSettings (sample, ground, vertical).");
}

}  // namespace

void bind_features(py::module_& m) {
  bind_fpfh(m);
  bind_sac_ia(m);
  bind_segmentation(m);
}

}  // namespace plumb::python
