// SPDX-License-Identifier: BSD-3-Clause
// File formats: PCD, PLY, KITTI .bin clouds; TUM and KITTI trajectories.
#include <filesystem>
#include <optional>
#include <string>

#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include "convert.hpp"
#include "plumb/io/kitti_bin.hpp"
#include "plumb/io/pcd.hpp"
#include "plumb/io/ply.hpp"
#include "plumb/io/trajectory.hpp"

namespace plumb::python {
namespace {

using Path = std::filesystem::path;
using OptionalPath = std::optional<Path>;
using Release = py::call_guard<py::gil_scoped_release>;

/// Bind `name(path, cloud, encoding=default_encoding)` calling `write` with the GIL released.
template <typename Encoding, typename Settings>
void def_cloud_writer(py::module_& m, const char* name,
                      void (*write)(const std::string&, const PointCloud&, const Settings&), Encoding default_encoding,
                      const char* doc) {
  m.def(
      name,
      [name, write](const Path& path, const py::object& cloud, Encoding encoding) {
        const PointCloud c = cloud_from_object(cloud, (std::string(name) + ": cloud").c_str());
        py::gil_scoped_release release;
        write(path.string(), c, Settings{encoding});
      },
      py::arg("path"), py::arg("cloud"), py::arg("encoding") = default_encoding, doc);
}

void bind_cloud_io(py::module_& m) {
  py::enum_<io::PcdEncoding>(m, "PcdEncoding", "How write_pcd() stores the point data.")
      .value("ascii", io::PcdEncoding::kAscii)
      .value("binary", io::PcdEncoding::kBinary)
      .value("binary_compressed", io::PcdEncoding::kBinaryCompressed);
  py::enum_<io::PlyEncoding>(m, "PlyEncoding", "How write_ply() stores the vertex data.")
      .value("ascii", io::PlyEncoding::kAscii)
      .value("binary_little_endian", io::PlyEncoding::kBinaryLittleEndian);

  m.def(
      "read_pcd",
      [](const Path& path, bool drop_non_finite) {
        io::PcdReadSettings settings;
        settings.drop_non_finite = drop_non_finite;
        return io::read_pcd(path.string(), settings);
      },
      py::arg("path"), py::arg("drop_non_finite") = false, Release(),
      "Read a PCD file (ascii, binary or binary_compressed) into a PointCloud: x y z, normal_x normal_y normal_z, "
      "intensity, ring, time and label; other fields are skipped.");
  def_cloud_writer<io::PcdEncoding>(
      m, "write_pcd", &io::write_pcd, io::PcdEncoding::kBinary,
      "Write a PointCloud (or an (N, 3) point array) as PCD v0.7 with every present field.");
  m.def(
      "read_ply", [](const Path& path) { return io::read_ply(path.string()); }, py::arg("path"), Release(),
      "Read the vertices of a PLY file (ascii or binary) into a PointCloud.");
  def_cloud_writer<io::PlyEncoding>(
      m, "write_ply", &io::write_ply, io::PlyEncoding::kBinaryLittleEndian,
      "Write a PointCloud (or an (N, 3) point array) as a PLY vertex element with every present field.");
  m.def(
      "read_kitti_bin", [](const Path& path) { return io::read_kitti_bin(path.string()); }, py::arg("path"),
      Release(), "Read a KITTI velodyne .bin scan: points and intensities.");
  m.def(
      "write_kitti_bin",
      [](const Path& path, const py::object& cloud) {
        const PointCloud c = cloud_from_object(cloud, "write_kitti_bin: cloud");
        py::gil_scoped_release release;
        io::write_kitti_bin(path.string(), c);
      },
      py::arg("path"), py::arg("cloud"), "Write x y z intensity float32 records (intensity 0 when absent).");
}

void bind_trajectory_io(py::module_& m) {
  py::class_<io::TrajectoryReadSettings>(m, "TrajectoryReadSettings",
                                         "How strictly read_tum() / read_kitti() treat their input.")
      .def(py::init<>())
      .def_readwrite("max_quaternion_norm_error", &io::TrajectoryReadSettings::max_quaternion_norm_error)
      .def_readwrite("max_rotation_error", &io::TrajectoryReadSettings::max_rotation_error)
      .def_readwrite("orthonormalize", &io::TrajectoryReadSettings::orthonormalize)
      .def_readwrite("require_increasing_stamps", &io::TrajectoryReadSettings::require_increasing_stamps)
      .def_readwrite("max_abs_coordinate", &io::TrajectoryReadSettings::max_abs_coordinate);

  m.def(
      "read_tum",
      [](const Path& path, const py::kwargs& kwargs) {
        const auto settings = settings_from_kwargs<io::TrajectoryReadSettings>(kwargs, "read_tum");
        py::gil_scoped_release release;
        return io::read_tum(path.string(), settings);
      },
      py::arg("path"),
      "Read a TUM trajectory (stamp tx ty tz qx qy qz qw per line). Keyword arguments: the fields of "
      "TrajectoryReadSettings.");
  m.def(
      "write_tum", [](const Trajectory& trajectory, const Path& path) { io::write_tum(trajectory, path.string()); },
      py::arg("trajectory"), py::arg("path"), Release(), "Write a TUM trajectory file; needs stamps.");
  m.def(
      "read_kitti",
      [](const Path& path, const OptionalPath& times_path, const py::kwargs& kwargs) {
        const auto settings = settings_from_kwargs<io::TrajectoryReadSettings>(kwargs, "read_kitti");
        py::gil_scoped_release release;
        return io::read_kitti(path.string(), times_path ? times_path->string() : std::string(), settings);
      },
      py::arg("path"), py::arg("times_path") = py::none(),
      "Read a KITTI pose file (12 numbers per line), with its times file if `times_path` is given. Keyword "
      "arguments: the fields of TrajectoryReadSettings.");
  m.def(
      "write_kitti",
      [](const Trajectory& trajectory, const Path& path, const OptionalPath& times_path) {
        io::write_kitti(trajectory, path.string(), times_path ? times_path->string() : std::string());
      },
      py::arg("trajectory"), py::arg("path"), py::arg("times_path") = py::none(), Release(),
      "Write a KITTI pose file, and the stamps to `times_path` when given.");
}

}  // namespace

void bind_io(py::module_& m) {
  bind_cloud_io(m);
  bind_trajectory_io(m);
}

}  // namespace plumb::python
