// SPDX-License-Identifier: BSD-3-Clause
// Registration: align_icp and its settings and result.
#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include "convert.hpp"
#include "plumb/core/robust_kernel.hpp"
#include "plumb/registration/icp.hpp"

namespace plumb::python {
namespace {

void bind_icp_settings(py::module_& m) {
  py::enum_<IcpMethod>(m, "IcpMethod", "Error metric of align_icp().")
      .value("point_to_point", IcpMethod::kPointToPoint)
      .value("point_to_plane", IcpMethod::kPointToPlane);
  py::enum_<RobustKernel>(m, "RobustKernel", "Kind of robust kernel (M-estimator).")
      .value("none", RobustKernel::kNone)
      .value("huber", RobustKernel::kHuber)
      .value("cauchy", RobustKernel::kCauchy)
      .value("tukey", RobustKernel::kTukey);
  py::class_<IcpSettings>(m, "IcpSettings", "Settings of align_icp(); the defaults are the C++ ones.")
      .def(py::init<>())
      .def_readwrite("method", &IcpSettings::method)
      .def_readwrite("max_correspondence_distance", &IcpSettings::max_correspondence_distance)
      .def_readwrite("distance_step", &IcpSettings::distance_step)
      .def_readwrite("min_correspondence_distance", &IcpSettings::min_correspondence_distance)
      .def_readwrite("max_rounds", &IcpSettings::max_rounds)
      .def_readwrite("max_iterations", &IcpSettings::max_iterations)
      .def_readwrite("tolerance", &IcpSettings::tolerance)
      .def_readwrite("min_step", &IcpSettings::min_step)
      .def_readwrite("min_overlap", &IcpSettings::min_overlap)
      .def_readwrite("overlap_distance", &IcpSettings::overlap_distance)
      .def_readwrite("max_normal_angle", &IcpSettings::max_normal_angle)
      .def_readwrite("kernel", &IcpSettings::kernel)
      .def_readwrite("kernel_scale", &IcpSettings::kernel_scale)
      .def_readwrite("min_correspondences", &IcpSettings::min_correspondences)
      .def_readwrite("degeneracy_threshold", &IcpSettings::degeneracy_threshold)
      .def_readwrite("keep_correspondences", &IcpSettings::keep_correspondences)
      .def_readwrite("threads", &IcpSettings::threads);
}

void bind_icp_result(py::module_& m) {
  py::class_<IcpCorrespondence>(m, "IcpCorrespondence", "One final source-target pair of align_icp().")
      .def_readonly("source_index", &IcpCorrespondence::source_index)
      .def_readonly("target_index", &IcpCorrespondence::target_index)
      .def_readonly("x", &IcpCorrespondence::x)
      .def_readonly("q", &IcpCorrespondence::q)
      .def_readonly("n", &IcpCorrespondence::n);
  py::class_<IcpResult>(m, "IcpResult", "Result of align_icp(); T_target_source is a 4x4 float64 array.")
      .def_property_readonly("T_target_source", [](const IcpResult& r) { return pose_to_array(r.T_target_source); })
      .def_readonly("status", &IcpResult::status)
      .def_readonly("converged", &IcpResult::converged)
      .def_readonly("iterations", &IcpResult::iterations)
      .def_readonly("rounds", &IcpResult::rounds)
      .def_readonly("num_inliers", &IcpResult::num_inliers)
      .def_readonly("overlap", &IcpResult::overlap)
      .def_readonly("rmse", &IcpResult::rmse)
      .def_readonly("final_correspondence_distance", &IcpResult::final_correspondence_distance)
      .def_readonly("degeneracy", &IcpResult::degeneracy)
      .def_readonly("normal_matrix", &IcpResult::normal_matrix)
      .def_readonly("normal_matrix_pivot", &IcpResult::normal_matrix_pivot)
      .def_readonly("correspondences", &IcpResult::correspondences);
}

}  // namespace

void bind_registration(py::module_& m) {
  bind_icp_settings(m);
  bind_icp_result(m);
  m.def(
      "align_icp",
      [](const py::object& source, const py::object& target, const py::object& T_init, const py::kwargs& kwargs) {
        const auto settings = settings_from_kwargs<IcpSettings>(kwargs, "align_icp");
        const PointCloud s = cloud_from_object(source, "align_icp: source");
        const PointCloud t = cloud_from_object(target, "align_icp: target");
        const Eigen::Isometry3d init =
            T_init.is_none() ? Eigen::Isometry3d::Identity() : pose_from_array(T_init, "align_icp: T_init");
        py::gil_scoped_release release;
        return align_icp(s, t, init, settings);
      },
      py::arg("source"), py::arg("target"), py::arg("T_init") = py::none(),
      "Align `source` to `target` (PointClouds or (N, 3) point arrays) from T_init (4x4, identity by default): "
      "overlap-gated ICP. Point-to-plane needs a target PointCloud with normals. Keyword arguments: the fields "
      "of IcpSettings.");
}

}  // namespace plumb::python
