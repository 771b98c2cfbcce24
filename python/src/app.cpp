// SPDX-License-Identifier: BSD-3-Clause
// The frame-dump runners behind `plumb run` and `plumb lio`: run_bim_odometry, run_lio.
#include <optional>

#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include "convert.hpp"
#include "plumb/app/lio_run.hpp"
#include "plumb/app/run.hpp"

namespace plumb::python {
namespace {

void bind_run_settings(py::module_& m) {
  py::class_<RunSettings>(m, "RunSettings", "Settings of run_bim_odometry() (the C++ defaults).")
      .def(py::init<>())
      .def_readwrite("odometry", &RunSettings::odometry)
      .def_readwrite("bim_spacing", &RunSettings::bim_spacing)
      .def_property(
          "initial_pose",
          [](const RunSettings& s) -> py::object {
            if (!s.initial_pose) return py::none();
            return pose_to_array(*s.initial_pose);
          },
          [](RunSettings& s, const py::object& pose) {
            if (pose.is_none()) {
              s.initial_pose.reset();
            } else {
              s.initial_pose = pose_from_array(pose, "initial_pose");
            }
          },
          "Initial base pose in the BIM frame (4x4), or None: localize the first frame (BimLocalizer).")
      .def_readwrite("localizer", &RunSettings::localizer)
      .def_readwrite("start_hint", &RunSettings::start_hint)
      .def_readwrite("start_hint_radius", &RunSettings::start_hint_radius)
      .def_readwrite("start_search_distance", &RunSettings::start_search_distance)
      .def_readwrite("start_view_spacing", &RunSettings::start_view_spacing)
      .def_readwrite("deskew", &RunSettings::deskew)
      .def_readwrite("max_frames", &RunSettings::max_frames)
      .def_readwrite("deviation_tolerance", &RunSettings::deviation_tolerance)
      .def_readwrite("refine_as_built", &RunSettings::refine_as_built);
  py::class_<ObservationRow>(m, "ObservationRow", "One row of Liu et al. 2022, Table 2.")
      .def_readonly("name", &ObservationRow::name)
      .def_readonly("frame", &ObservationRow::frame)
      .def_readonly("distance", &ObservationRow::distance)
      .def_readonly("error_wheel", &ObservationRow::error_wheel)
      .def_readonly("error_lidar", &ObservationRow::error_lidar)
      .def_readonly("error_bim", &ObservationRow::error_bim)
      .def_readonly("error_refined", &ObservationRow::error_refined);
}

void bind_run_report(py::module_& m) {
  py::class_<RunReport> r(m, "RunReport", "Everything run_bim_odometry() produced.");
  r.def_readonly("wheel", &RunReport::wheel)
      .def_readonly("lidar", &RunReport::lidar)
      .def_readonly("bim", &RunReport::bim)
      .def_readonly("bim_refined", &RunReport::bim_refined)
      .def_readonly("frames", &RunReport::frames)
      .def_readonly("frames_requested", &RunReport::frames_requested)
      .def_readonly("partial", &RunReport::partial)
      .def_readonly("error", &RunReport::error)
      .def_readonly("warnings", &RunReport::warnings)
      .def_readonly("odometry_clamped_frames", &RunReport::odometry_clamped_frames)
      .def_readonly("localized", &RunReport::localized)
      .def_readonly("localization_status", &RunReport::localization_status)
      .def_readonly("localization", &RunReport::localization)
      .def_readonly("localization_distance", &RunReport::localization_distance)
      .def_readonly("localization_frames", &RunReport::localization_frames)
      .def_readonly("bim_points", &RunReport::bim_points)
      .def_readonly("anchors_accepted", &RunReport::anchors_accepted)
      .def_readonly("anchors_rejected", &RunReport::anchors_rejected)
      .def_readonly("anchors_attempted", &RunReport::anchors_attempted)
      .def_readonly("fallbacks", &RunReport::fallbacks)
      .def_readonly("seconds_localize", &RunReport::seconds_localize)
      .def_readonly("seconds_frames", &RunReport::seconds_frames)
      .def_readonly("seconds_refine", &RunReport::seconds_refine)
      .def_readonly("frames_per_second", &RunReport::frames_per_second)
      .def_readonly("median_seconds_process", &RunReport::median_seconds_process)
      .def_readonly("max_seconds_process", &RunReport::max_seconds_process)
      .def_readonly("slowest_frame", &RunReport::slowest_frame)
      .def_readonly("has_ground_truth", &RunReport::has_ground_truth)
      .def_readonly("ground_truth_note", &RunReport::ground_truth_note)
      .def_readonly("initial_error_xy", &RunReport::initial_error_xy)
      .def_readonly("initial_error_yaw_deg", &RunReport::initial_error_yaw_deg)
      .def_readonly("table", &RunReport::table)
      .def_readonly("path_length", &RunReport::path_length)
      .def_readonly("ape_rmse_wheel", &RunReport::ape_rmse_wheel)
      .def_readonly("ape_rmse_lidar", &RunReport::ape_rmse_lidar)
      .def_readonly("ape_rmse_bim", &RunReport::ape_rmse_bim)
      .def_readonly("max_error_wheel", &RunReport::max_error_wheel)
      .def_readonly("max_error_lidar", &RunReport::max_error_lidar)
      .def_readonly("max_error_bim", &RunReport::max_error_bim)
      .def_readonly("ape_rmse_refined", &RunReport::ape_rmse_refined)
      .def_readonly("max_error_refined", &RunReport::max_error_refined)
      .def_readonly("registrations", &RunReport::registrations)
      .def_readonly("registration_error_rms", &RunReport::registration_error_rms)
      .def_readonly("registration_error_max", &RunReport::registration_error_max)
      .def_readonly("deviations", &RunReport::deviations)
      .def_readonly("deviation_tolerance", &RunReport::deviation_tolerance);
  def_pose(r, "T_world_base0", &RunReport::T_world_base0);
}

void bind_lio_run(py::module_& m) {
  py::class_<LioRunSettings>(m, "LioRunSettings", "Settings of run_lio().")
      .def(py::init<>())
      .def_readwrite("lio", &LioRunSettings::lio)
      .def_readwrite("max_frames", &LioRunSettings::max_frames);
  py::class_<LioRunReport>(m, "LioRunReport", "Everything run_lio() produced.")
      .def_readonly("trajectory", &LioRunReport::trajectory)
      .def_readonly("frames", &LioRunReport::frames)
      .def_readonly("frames_requested", &LioRunReport::frames_requested)
      .def_readonly("first_frame", &LioRunReport::first_frame)
      .def_readonly("partial", &LioRunReport::partial)
      .def_readonly("error", &LioRunReport::error)
      .def_readonly("warnings", &LioRunReport::warnings)
      .def_readonly("imu_gaps", &LioRunReport::imu_gaps)
      .def_readonly("not_converged", &LioRunReport::not_converged)
      .def_readonly("imu_samples_dropped", &LioRunReport::imu_samples_dropped)
      .def_readonly("frames_per_second", &LioRunReport::frames_per_second)
      .def_readonly("has_ground_truth", &LioRunReport::has_ground_truth)
      .def_readonly("ground_truth_note", &LioRunReport::ground_truth_note)
      .def_readonly("has_metrics", &LioRunReport::has_metrics)
      .def_readonly("path_length", &LioRunReport::path_length)
      .def_readonly("end_error", &LioRunReport::end_error)
      .def_readonly("end_error_xy", &LioRunReport::end_error_xy)
      .def_readonly("ape_rmse", &LioRunReport::ape_rmse)
      .def_readonly("max_error", &LioRunReport::max_error)
      .def_readonly("rpe_pairs", &LioRunReport::rpe_pairs)
      .def_readonly("rpe_translation_mean", &LioRunReport::rpe_translation_mean)
      .def_readonly("rpe_translation_rmse", &LioRunReport::rpe_translation_rmse)
      .def_readonly("rpe_rotation_mean_deg", &LioRunReport::rpe_rotation_mean_deg)
      .def("frames_in", &LioRunReport::frames_in, py::arg("mode"));
}

}  // namespace

void bind_app(py::module_& m) {
  bind_run_settings(m);
  bind_run_report(m);
  bind_lio_run(m);
  m.def(
      "run_bim_odometry",
      [](const io::FrameDumpReader& dump, const bim::BimMesh& mesh, const py::kwargs& kwargs) {
        const auto settings = settings_from_kwargs<RunSettings>(kwargs, "run_bim_odometry");
        py::gil_scoped_release release;
        return run_bim_odometry(dump, mesh, settings);
      },
      py::arg("dump"), py::arg("mesh"),
      "The BIM-corrected odometry over a FrameDump (what `plumb run` does): BIM cloud, localization of the first "
      "frame, deskewing, BimOdometry per frame, and the error table against gt.tum. Keyword arguments: the fields "
      "of RunSettings.");
  m.def(
      "run_lio",
      [](const io::FrameDumpReader& dump, const py::kwargs& kwargs) {
        const auto settings = settings_from_kwargs<LioRunSettings>(kwargs, "run_lio");
        py::gil_scoped_release release;
        return run_lio(dump, settings);
      },
      py::arg("dump"),
      "HybridLio over a FrameDump (what `plumb lio` does). Keyword arguments: the fields of LioRunSettings.");
}

}  // namespace plumb::python
