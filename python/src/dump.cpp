// SPDX-License-Identifier: BSD-3-Clause
// Frame dumps (io::FrameDumpReader), the wheel-odometry interpolator and deskewing.
#include <filesystem>
#include <memory>
#include <string>

#include <pybind11/eigen.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include "convert.hpp"
#include "plumb/core/deskew.hpp"
#include "plumb/io/frame_dump.hpp"

namespace plumb::python {
namespace {

using Release = py::call_guard<py::gil_scoped_release>;

/// Iterator over a dump's frames: (stamp, PointCloud) pairs, each frame read when reached.
struct FrameIterator {
  std::shared_ptr<const io::FrameDumpReader> dump;
  std::size_t next = 0;
};

py::array odometry_table(const std::vector<OdomSample>& odometry) {
  return table_to_array(odometry, 4, [](const OdomSample& s, double* row) {
    row[0] = s.stamp;
    row[1] = s.pose.x;
    row[2] = s.pose.y;
    row[3] = s.pose.theta;
  });
}

void bind_meta(py::module_& m) {
  py::class_<io::DumpLidar>(m, "DumpLidar", "The LiDAR as meta.json describes it.")
      .def_readonly("name", &io::DumpLidar::name)
      .def_readonly("rate_hz", &io::DumpLidar::rate_hz)
      .def_readonly("columns", &io::DumpLidar::columns)
      .def_property_readonly("elevations_rad",
                             [](const io::DumpLidar& l) { return vector_to_array(l.elevations_rad); })
      .def_readonly("min_range", &io::DumpLidar::min_range)
      .def_readonly("max_range", &io::DumpLidar::max_range);
  py::class_<io::FrameDumpMeta>(m, "FrameDumpMeta", "Contents of a dump's meta.json; transforms are 4x4 arrays.")
      .def_readonly("lidar", &io::FrameDumpMeta::lidar)
      .def_property_readonly("T_base_lidar", [](const io::FrameDumpMeta& d) { return pose_to_array(d.T_base_lidar); })
      .def_property_readonly("T_base_imu", [](const io::FrameDumpMeta& d) { return pose_to_array(d.T_base_imu); })
      .def_readonly("wheel_radius_left", &io::FrameDumpMeta::wheel_radius_left)
      .def_readonly("wheel_radius_right", &io::FrameDumpMeta::wheel_radius_right)
      .def_readonly("axle", &io::FrameDumpMeta::axle)
      .def_readonly("imu_rate_hz", &io::FrameDumpMeta::imu_rate_hz)
      .def_readonly("origin_offset", &io::FrameDumpMeta::origin_offset)
      .def_readonly("source", &io::FrameDumpMeta::source)
      .def_readonly("model", &io::FrameDumpMeta::model)
      .def_readonly("scenario", &io::FrameDumpMeta::scenario);
}

void bind_reader(py::module_& m) {
  using Reader = io::FrameDumpReader;
  py::class_<FrameIterator>(m, "FrameDumpIterator", "Iterator over (stamp, PointCloud) pairs of a FrameDump.")
      .def("__iter__", [](FrameIterator& it) -> FrameIterator& { return it; })
      .def("__next__", [](FrameIterator& it) {
        if (it.next >= it.dump->num_frames()) throw py::stop_iteration();
        const std::size_t i = it.next++;
        PointCloud frame;
        {
          py::gil_scoped_release release;
          frame = it.dump->frame(i);
        }
        return py::make_tuple(it.dump->stamp(i), std::move(frame));
      });
  py::class_<Reader, std::shared_ptr<Reader>>(
      m, "FrameDump",
      "A frame dump directory (io::FrameDumpReader): opening reads meta.json and frames.csv; frames and the other "
      "files are read when asked for. Iterating gives (stamp, PointCloud) pairs, the LiDAR frames with their "
      "per-point fields (intensities, rings, times, labels) as stored.")
      .def(py::init([](const std::filesystem::path& dir) { return std::make_shared<Reader>(dir.string()); }),
           py::arg("path"), Release())
      .def_property_readonly("meta", &Reader::meta)
      .def_property_readonly("dir", &Reader::dir)
      .def("num_frames", &Reader::num_frames)
      .def("__len__", &Reader::num_frames)
      .def("stamp", &Reader::stamp, py::arg("i"))
      .def_property_readonly("stamps", [](const Reader& d) { return vector_to_array(d.stamps()); })
      .def("frame_path", &Reader::frame_path, py::arg("i"))
      .def("frame", &Reader::frame, py::arg("i"), Release(), "Read frame i (LiDAR frame, fields as stored).")
      .def("__iter__", [](const std::shared_ptr<Reader>& d) { return FrameIterator{d, 0}; })
      .def("has_wheels", &Reader::has_wheels)
      .def("has_odometry", &Reader::has_odometry)
      .def("has_imu", &Reader::has_imu)
      .def("has_ground_truth", &Reader::has_ground_truth)
      .def("has_ground_truth_dense", &Reader::has_ground_truth_dense)
      .def(
          "wheels",
          [](const Reader& d) {
            return table_to_array(d.wheels(), 3, [](const WheelEncoderReading& w, double* row) {
              row[0] = w.stamp;
              row[1] = w.left;
              row[2] = w.right;
            });
          },
          "wheels.csv as an (N, 3) float64 array: stamp, left, right (cumulative wheel angles [rad]).")
      .def(
          "odometry", [](const Reader& d) { return odometry_table(d.odometry()); },
          "odom.csv as an (N, 4) float64 array: stamp, x, y, theta.")
      .def(
          "imu",
          [](const Reader& d) {
            return table_to_array(d.imu(), 7, [](const ImuSample& s, double* row) {
              row[0] = s.stamp;
              for (int a = 0; a < 3; ++a) {
                row[1 + a] = s.gyro[a];
                row[4 + a] = s.accel[a];
              }
            });
          },
          "imu.csv as an (N, 7) float64 array: stamp, wx, wy, wz [rad/s], ax, ay, az [m/s^2] (IMU frame).")
      .def("ground_truth", &Reader::ground_truth, Release(), "gt.tum: the true T_world_base at the frame stamps.")
      .def("ground_truth_dense", &Reader::ground_truth_dense, Release(), "gt_dense.tum (dense ground truth).");
}

void bind_odometry(py::module_& m) {
  py::class_<OdometryInterpolator>(m, "OdometryInterpolator",
                                   "Wheel-odometry poses at any time, interpolated on SE(2) between samples and held "
                                   "at the nearest sample outside their span.")
      .def(py::init([](const py::object& samples) {
             const auto table = table_from_array(samples, "OdometryInterpolator: samples", 4);
             std::vector<OdomSample> s(static_cast<std::size_t>(table.shape(0)));
             for (std::size_t i = 0; i < s.size(); ++i) {
               const double* row = table.data() + 4 * i;
               s[i] = OdomSample{row[0], Pose2{row[1], row[2], row[3]}};
             }
             return OdometryInterpolator(std::move(s));
           }),
           py::arg("samples"), "From an (N, 4) array of stamp, x, y, theta rows (FrameDump.odometry()).")
      .def("at", [](const OdometryInterpolator& o, double t) { return pose2_to_array(o.at(t)); }, py::arg("t"),
           "The pose (x, y, theta) at time t, a (3,) float64 array.")
      .def("first_stamp", &OdometryInterpolator::first_stamp)
      .def("last_stamp", &OdometryInterpolator::last_stamp);

  m.def(
      "deskew_frame",
      [](const PointCloud& frame, double stamp, const py::object& T_base_lidar, const OdometryInterpolator& odometry) {
        PointCloud out = frame;
        const Eigen::Isometry3d T = pose_from_array(T_base_lidar, "deskew_frame: T_base_lidar");
        py::gil_scoped_release release;
        deskew_frame(out, stamp, T, [&](double t) { return odometry.at(t).to_isometry(); });
        return out;
      },
      py::arg("frame"), py::arg("stamp"), py::arg("T_base_lidar"), py::arg("odometry"),
      "A copy of `frame` with every point moved to where it is at `stamp` (its per-point `times` are seconds since "
      "the stamp), the base's motion taken from `odometry` (an OdometryInterpolator).");
}

}  // namespace

void bind_dump(py::module_& m) {
  bind_meta(m);
  bind_reader(m);
  bind_odometry(m);
}

}  // namespace plumb::python
