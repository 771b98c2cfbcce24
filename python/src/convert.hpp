// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Conversions between numpy arrays and plumb's types for the Python module, and the
///        keyword-argument settings of its functions.
///
/// Point arrays are (N, 3) float32 (float64 is converted); poses are 4x4 float64. An array of
/// another shape or dtype raises ValueError naming what was expected and what was given.

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include "plumb/core/point_cloud.hpp"
#include "plumb/core/pose2.hpp"
#include "plumb/core/trajectory.hpp"
#include "plumb/core/types.hpp"

namespace plumb::python {

namespace py = pybind11;

/// @brief (N, 3) float32 or float64 array -> points (float). `what` names the argument in errors.
std::vector<Vector3f> points_from_array(const py::handle& obj, const char* what);
/// @brief (N, 3) float32 or float64 array -> positions (double).
std::vector<Vector3d> positions_from_array(const py::handle& obj, const char* what);
/// @brief (3,) float32 or float64 array -> one point (float).
Vector3f point_from_array(const py::handle& obj, const char* what);
/// @brief Points -> a new (N, 3) float32 array.
py::array_t<float> points_to_array(const std::vector<Vector3f>& points);

/// @brief (N,) float array -> floats / doubles.
std::vector<float> floats_from_array(const py::handle& obj, const char* what);
std::vector<double> doubles_from_array(const py::handle& obj, const char* what);
/// @brief (N,) integer array whose values fit Int -> values.
template <typename Int>
std::vector<Int> ints_from_array(const py::handle& obj, const char* what);

/// @brief A vector -> a new 1-D array of the same element type (std::size_t -> int64).
template <typename T>
py::array vector_to_array(const std::vector<T>& values);
py::array indices_to_array(const std::vector<std::size_t>& indices);

/// @brief 4x4 float array with last row (0, 0, 0, 1) -> isometry.
Eigen::Isometry3d pose_from_array(const py::handle& obj, const char* what);
/// @brief Isometry -> a new 4x4 float64 array.
py::array_t<double> pose_to_array(const Eigen::Isometry3d& pose);
/// @brief (N, 4, 4) float array -> isometries; poses -> a new (N, 4, 4) float64 array.
std::vector<Eigen::Isometry3d> poses_from_array(const py::handle& obj, const char* what);
py::array_t<double> poses_to_array(const std::vector<Eigen::Isometry3d>& poses);

/// @brief (3,) float array (x, y, theta) -> planar pose; planar pose -> a new (3,) float64 array.
Pose2 pose2_from_array(const py::handle& obj, const char* what);
py::array_t<double> pose2_to_array(const Pose2& pose);

/// @brief (N, cols) float32 or float64 array -> a C-contiguous float64 array of that shape.
py::array_t<double, py::array::c_style | py::array::forcecast> table_from_array(const py::handle& obj,
                                                                                 const char* what, py::ssize_t cols);
/// @brief Records -> a new (N, cols) float64 array; `fill(record, row)` writes the `cols` values of a row.
template <typename Record, typename Fill>
py::array_t<double> table_to_array(const std::vector<Record>& records, py::ssize_t cols, Fill fill) {
  py::array_t<double> out({static_cast<py::ssize_t>(records.size()), cols});
  double* dst = out.mutable_data();
  for (std::size_t i = 0; i < records.size(); ++i) fill(records[i], dst + i * static_cast<std::size_t>(cols));
  return out;
}

/// @brief A 4x4 float64 array property of a bound class for an isometry member (read-only, or
///        read-write when `writable`: assigning checks the array as pose_from_array()).
template <typename Class, typename... Options>
void def_pose(py::class_<Class, Options...>& cls, const char* name, Eigen::Isometry3d Class::*member,
              bool writable = false) {
  auto get = [member](const Class& c) { return pose_to_array(c.*member); };
  if (!writable) {
    cls.def_property_readonly(name, get);
    return;
  }
  cls.def_property(name, get, [member, name](Class& c, const py::object& value) {
    c.*member = pose_from_array(value, name);
  });
}

/// @brief A plumb.PointCloud (copied) or an (N, 3) point array (a cloud without fields).
PointCloud cloud_from_object(const py::handle& obj, const char* what);

/// @brief Settings built from a function's keyword arguments: `settings=` (a bound settings
///        object) as the start, else the C++ defaults; every other keyword sets the field of that
///        name. An unknown keyword raises TypeError naming the function and the settings type.
template <typename Settings>
Settings settings_from_kwargs(const py::kwargs& kwargs, const char* function) {
  py::object settings = py::cast(Settings{});
  if (kwargs.contains("settings")) settings = py::cast(kwargs["settings"].cast<Settings>());
  for (const auto& item : kwargs) {
    const std::string name = py::str(item.first);
    if (name == "settings") continue;
    if (name.empty() || name[0] == '_' || !py::hasattr(settings, name.c_str())) {
      const std::string type = py::str(py::type::of(settings).attr("__name__"));
      throw py::type_error(std::string(function) + "() got an unexpected keyword argument '" + name +
                           "' (not a field of " + type + ")");
    }
    settings.attr(name.c_str()) = item.second;
  }
  return settings.cast<Settings>();
}

/// @brief The bindings of each area, called by the module in this order.
void bind_core(py::module_& m);
void bind_io(py::module_& m);
void bind_algorithms(py::module_& m);
void bind_registration(py::module_& m);
void bind_eval(py::module_& m);
void bind_dump(py::module_& m);
void bind_bim(py::module_& m);
void bind_pipeline(py::module_& m);
void bind_app(py::module_& m);
void bind_features(py::module_& m);
void bind_scan2d(py::module_& m);

}  // namespace plumb::python
