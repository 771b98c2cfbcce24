// SPDX-License-Identifier: BSD-3-Clause
// plumb.Error, plumb.Status, plumb.PointCloud and plumb.Trajectory.
#include <cstdint>

#include "convert.hpp"
#include "plumb/core/allocator.hpp"
#include "plumb/core/error.hpp"
#include "plumb/core/point_cloud.hpp"
#include "plumb/core/status.hpp"
#include "plumb/core/trajectory.hpp"
#include "plumb/version.hpp"

namespace plumb::python {
namespace {

/// Setter of a field from an array; None empties it.
template <typename T, typename Convert>
void set_field(std::vector<T>& field, const py::object& value, const char* what, Convert convert) {
  if (value.is_none()) {
    field.clear();
    return;
  }
  field = convert(value, what);
}

PointCloud make_cloud(const py::object& points, const py::object& normals, const py::object& intensities,
                      const py::object& rings, const py::object& times, const py::object& labels) {
  PointCloud cloud;
  set_field(cloud.points, points, "PointCloud.points", points_from_array);
  set_field(cloud.normals, normals, "PointCloud.normals", points_from_array);
  set_field(cloud.intensities, intensities, "PointCloud.intensities", floats_from_array);
  set_field(cloud.rings, rings, "PointCloud.rings", ints_from_array<std::uint16_t>);
  set_field(cloud.times, times, "PointCloud.times", floats_from_array);
  set_field(cloud.labels, labels, "PointCloud.labels", ints_from_array<std::int32_t>);
  cloud.check_consistent("PointCloud");
  return cloud;
}

void bind_point_cloud(py::module_& m) {
  py::class_<PointCloud>(m, "PointCloud",
                         "A point cloud as arrays: `points` (N, 3) float32 and the optional fields `normals` "
                         "(N, 3) float32, `intensities` (N,) float32, `rings` (N,) uint16, `times` (N,) float32 [s] "
                         "and `labels` (N,) int32. An absent field is an empty array. Reading a field returns a "
                         "copy; assign the field to change it.")
      .def(py::init(&make_cloud), py::arg("points") = py::none(), py::arg("normals") = py::none(),
           py::arg("intensities") = py::none(), py::arg("rings") = py::none(), py::arg("times") = py::none(),
           py::arg("labels") = py::none())
      .def_property(
          "points", [](const PointCloud& c) { return points_to_array(c.points); },
          [](PointCloud& c, const py::object& v) { set_field(c.points, v, "PointCloud.points", points_from_array); })
      .def_property(
          "normals", [](const PointCloud& c) { return points_to_array(c.normals); },
          [](PointCloud& c, const py::object& v) { set_field(c.normals, v, "PointCloud.normals", points_from_array); })
      .def_property(
          "intensities", [](const PointCloud& c) { return vector_to_array(c.intensities); },
          [](PointCloud& c, const py::object& v) {
            set_field(c.intensities, v, "PointCloud.intensities", floats_from_array);
          })
      .def_property(
          "rings", [](const PointCloud& c) { return vector_to_array(c.rings); },
          [](PointCloud& c, const py::object& v) {
            set_field(c.rings, v, "PointCloud.rings", ints_from_array<std::uint16_t>);
          })
      .def_property(
          "times", [](const PointCloud& c) { return vector_to_array(c.times); },
          [](PointCloud& c, const py::object& v) { set_field(c.times, v, "PointCloud.times", floats_from_array); })
      .def_property(
          "labels", [](const PointCloud& c) { return vector_to_array(c.labels); },
          [](PointCloud& c, const py::object& v) {
            set_field(c.labels, v, "PointCloud.labels", ints_from_array<std::int32_t>);
          })
      .def("size", &PointCloud::size)
      .def("__len__", &PointCloud::size)
      .def("empty", &PointCloud::empty)
      .def("has_normals", &PointCloud::has_normals)
      .def("has_intensities", &PointCloud::has_intensities)
      .def("has_rings", &PointCloud::has_rings)
      .def("has_times", &PointCloud::has_times)
      .def("has_labels", &PointCloud::has_labels)
      .def(
          "check_consistent", [](const PointCloud& c) { c.check_consistent(); },
          "Raise plumb.Error when an optional field is present with the wrong length.")
      .def(
          "select",
          [](const PointCloud& c, const py::object& indices) {
            const auto idx = ints_from_array<std::int64_t>(indices, "PointCloud.select: indices");
            std::vector<std::size_t> sel;
            sel.reserve(idx.size());
            for (const std::int64_t i : idx) {
              if (i < 0) throw py::value_error("PointCloud.select: indices must be >= 0");
              sel.push_back(static_cast<std::size_t>(i));
            }
            return c.select(sel);
          },
          py::arg("indices"), "Copy of the points (and every present field) at `indices`, in that order.")
      .def("__repr__", [](const PointCloud& c) {
        std::string fields;
        if (c.has_normals()) fields += " normals";
        if (c.has_intensities()) fields += " intensities";
        if (c.has_rings()) fields += " rings";
        if (c.has_times()) fields += " times";
        if (c.has_labels()) fields += " labels";
        return "<plumb.PointCloud of " + std::to_string(c.size()) + " points" + (fields.empty() ? "" : ";" + fields) +
               ">";
      });
}

Trajectory make_trajectory(const py::object& poses, const py::object& stamps) {
  Trajectory trajectory;
  set_field(trajectory.poses, poses, "Trajectory.poses", poses_from_array);
  set_field(trajectory.stamps, stamps, "Trajectory.stamps", doubles_from_array);
  trajectory.check_consistent("Trajectory");
  return trajectory;
}

void bind_trajectory(py::module_& m) {
  py::class_<Trajectory>(m, "Trajectory",
                         "A stamped sequence of poses T_world_body: `poses` (N, 4, 4) float64 and `stamps` (N,) "
                         "float64 [s], or an empty array when the trajectory has no stamps. Reading a field returns "
                         "a copy.")
      .def(py::init(&make_trajectory), py::arg("poses") = py::none(), py::arg("stamps") = py::none())
      .def_property(
          "poses", [](const Trajectory& t) { return poses_to_array(t.poses); },
          [](Trajectory& t, const py::object& v) { set_field(t.poses, v, "Trajectory.poses", poses_from_array); })
      .def_property(
          "stamps", [](const Trajectory& t) { return vector_to_array(t.stamps); },
          [](Trajectory& t, const py::object& v) { set_field(t.stamps, v, "Trajectory.stamps", doubles_from_array); })
      .def("size", &Trajectory::size)
      .def("__len__", &Trajectory::size)
      .def("empty", &Trajectory::empty)
      .def("has_stamps", &Trajectory::has_stamps)
      .def(
          "push_back",
          [](Trajectory& t, double stamp, const py::object& pose) {
            t.push_back(stamp, pose_from_array(pose, "Trajectory.push_back: pose"));
          },
          py::arg("stamp"), py::arg("T_world_body"))
      .def(
          "check_consistent", [](const Trajectory& t) { t.check_consistent(); },
          "Raise plumb.Error when stamps and poses disagree in length.")
      .def("__repr__", [](const Trajectory& t) {
        return "<plumb.Trajectory of " + std::to_string(t.size()) + " poses" + (t.has_stamps() ? "" : ", no stamps") +
               ">";
      });
}

}  // namespace

void bind_core(py::module_& m) {
  py::register_exception<Error>(m, "Error", PyExc_RuntimeError);
  m.def("version", &plumb::version, "The version of the compiled plumb library.");
  m.def("keep_freed_memory", &plumb::keep_freed_memory,
        "Ask glibc's allocator to keep freed memory for reuse (mmap threshold 32 MiB, trim threshold\n"
        "64 MiB) instead of faulting a frame's buffers in again every frame. Affects the whole\n"
        "process. True when applied, False where the C library has no such setting.");

  py::enum_<Status>(m, "Status", "Outcome of an algorithm; failure to converge is a Status, never an exception.")
      .value("ok", Status::kOk)
      .value("not_converged", Status::kNotConverged)
      .value("insufficient_data", Status::kInsufficientData)
      .value("degenerate", Status::kDegenerate)
      .value("rejected", Status::kRejected)
      .value("invalid_input", Status::kInvalidInput);

  bind_point_cloud(m);
  bind_trajectory(m);
}

}  // namespace plumb::python
