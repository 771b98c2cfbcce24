// SPDX-License-Identifier: BSD-3-Clause
// Planar scans: LaserScan, cloud_to_scan, PLICP, and the odometry/laser calibration.
#include <filesystem>
#include <limits>
#include <vector>

#include <pybind11/eigen.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include "convert.hpp"
#include "plumb/calibration/odometry_laser.hpp"
#include "plumb/core/laser_scan.hpp"
#include "plumb/io/calib_tuples.hpp"
#include "plumb/scan2d/cloud_to_scan.hpp"
#include "plumb/scan2d/plicp.hpp"

namespace plumb::python {
namespace {

py::array_t<double> points2_to_array(const std::vector<Vector2d>& points) {
  return table_to_array(points, 2, [](const Vector2d& p, double* row) {
    row[0] = p.x();
    row[1] = p.y();
  });
}

void bind_laser_scan(py::module_& m) {
  py::class_<LaserScan>(m, "LaserScan",
                        "A planar scan: ranges (float32, one per beam), regular beams at angle_min + i * "
                        "angle_increment unless `angles` (one per beam) is given.")
      .def(py::init([](const py::object& ranges, double angle_min, double angle_increment, double range_min,
                       double range_max, const py::object& angles, double stamp) {
             LaserScan s;
             s.ranges = floats_from_array(ranges, "LaserScan: ranges");
             if (!angles.is_none()) s.angles = floats_from_array(angles, "LaserScan: angles");
             s.angle_min = angle_min;
             s.angle_increment = angle_increment;
             s.range_min = range_min;
             s.range_max = range_max;
             s.stamp = stamp;
             s.check_consistent("LaserScan");
             return s;
           }),
           py::arg("ranges"), py::arg("angle_min") = 0.0, py::arg("angle_increment") = 0.0, py::arg("range_min") = 0.0,
           py::arg("range_max") = std::numeric_limits<double>::infinity(), py::arg("angles") = py::none(),
           py::arg("stamp") = 0.0)
      .def_property_readonly("ranges", [](const LaserScan& s) { return vector_to_array(s.ranges); })
      .def_property_readonly("angles", [](const LaserScan& s) { return vector_to_array(s.angles); })
      .def_readonly("angle_min", &LaserScan::angle_min)
      .def_readonly("angle_increment", &LaserScan::angle_increment)
      .def_readonly("range_min", &LaserScan::range_min)
      .def_readonly("range_max", &LaserScan::range_max)
      .def_readonly("stamp", &LaserScan::stamp)
      .def("__len__", &LaserScan::size)
      .def("num_valid", &LaserScan::num_valid);

  py::class_<CloudToScanSettings> s(m, "CloudToScanSettings", "Settings of cloud_to_scan() (the C++ defaults).");
  s.def(py::init<>())
      .def_readwrite("min_height", &CloudToScanSettings::min_height)
      .def_readwrite("max_height", &CloudToScanSettings::max_height)
      .def_readwrite("angle_min", &CloudToScanSettings::angle_min)
      .def_readwrite("angle_max", &CloudToScanSettings::angle_max)
      .def_readwrite("angle_increment", &CloudToScanSettings::angle_increment)
      .def_readwrite("range_min", &CloudToScanSettings::range_min)
      .def_readwrite("range_max", &CloudToScanSettings::range_max)
      .def_readwrite("stamp", &CloudToScanSettings::stamp);
  def_pose(s, "T_target_sensor", &CloudToScanSettings::T_target_sensor, true);
  py::class_<CloudToScanResult>(m, "CloudToScanResult",
                                "scan (LaserScan), points (M, 2) float64 behind the non-empty bins, their "
                                "beam_indices and source_indices (int64).")
      .def_readonly("scan", &CloudToScanResult::scan)
      .def_property_readonly("points", [](const CloudToScanResult& r) { return points2_to_array(r.points); })
      .def_property_readonly("beam_indices", [](const CloudToScanResult& r) { return indices_to_array(r.beam_indices); })
      .def_property_readonly("source_indices",
                             [](const CloudToScanResult& r) { return indices_to_array(r.source_indices); })
      .def_readonly("num_in_band", &CloudToScanResult::num_in_band)
      .def_readonly("status", &CloudToScanResult::status);
  m.def(
      "cloud_to_scan",
      [](const py::object& cloud, const py::kwargs& kwargs) {
        const auto settings = settings_from_kwargs<CloudToScanSettings>(kwargs, "cloud_to_scan");
        const PointCloud c = cloud_from_object(cloud, "cloud_to_scan: cloud");
        py::gil_scoped_release release;
        return cloud_to_scan(c, settings);
      },
      py::arg("cloud"),
      "Cut a height band of a 3D cloud into a planar scan: per angular bin the nearest horizontal range. Keyword "
      "arguments: the fields of CloudToScanSettings.");
}

void bind_plicp(py::module_& m) {
  py::class_<PlicpSettings>(m, "PlicpSettings", "Settings of plicp() (the C++ defaults).")
      .def(py::init<>())
      .def_readwrite("max_iterations", &PlicpSettings::max_iterations)
      .def_readwrite("epsilon_xy", &PlicpSettings::epsilon_xy)
      .def_readwrite("epsilon_theta", &PlicpSettings::epsilon_theta)
      .def_readwrite("max_correspondence_distance", &PlicpSettings::max_correspondence_distance)
      .def_readwrite("max_normal_angle", &PlicpSettings::max_normal_angle)
      .def_readwrite("max_step_xy", &PlicpSettings::max_step_xy)
      .def_readwrite("max_step_theta", &PlicpSettings::max_step_theta)
      .def_readwrite("trim_fraction", &PlicpSettings::trim_fraction)
      .def_readwrite("min_valid_pairs", &PlicpSettings::min_valid_pairs)
      .def_readwrite("sigma", &PlicpSettings::sigma)
      .def_readwrite("degeneracy_threshold", &PlicpSettings::degeneracy_threshold);
  py::class_<PlicpResult>(m, "PlicpResult", "Result of plicp(); T_ref_cur is (x, y, theta).")
      .def_property_readonly("T_ref_cur", [](const PlicpResult& r) { return pose2_to_array(r.T_ref_cur); })
      .def_readonly("status", &PlicpResult::status)
      .def_readonly("converged", &PlicpResult::converged)
      .def_readonly("iterations", &PlicpResult::iterations)
      .def_readonly("num_points", &PlicpResult::num_points)
      .def_readonly("num_valid_pairs", &PlicpResult::num_valid_pairs)
      .def_readonly("valid_fraction", &PlicpResult::valid_fraction)
      .def_readonly("mse", &PlicpResult::mse)
      .def_readonly("covariance", &PlicpResult::covariance)
      .def_readonly("degenerate", &PlicpResult::degenerate);
  m.def(
      "plicp",
      [](const LaserScan& current, const LaserScan& reference, const py::object& guess, const py::kwargs& kwargs) {
        const auto settings = settings_from_kwargs<PlicpSettings>(kwargs, "plicp");
        const Pose2 g = guess.is_none() ? Pose2{} : pose2_from_array(guess, "plicp: T_ref_cur_guess");
        py::gil_scoped_release release;
        return plicp(current, reference, g, settings);
      },
      py::arg("current"), py::arg("reference"), py::arg("T_ref_cur_guess") = py::none(),
      "Point-to-line ICP (Censi 2008) of the `current` scan against the `reference` scan from a guess (x, y, "
      "theta; zero by default). Keyword arguments: the fields of PlicpSettings.");
}

void bind_calibration(py::module_& m) {
  py::class_<OdometryLaserCalibrationSettings>(m, "OdometryLaserCalibrationSettings",
                                               "Settings of calibrate_odometry_laser().")
      .def(py::init<>())
      .def_readwrite("outlier_iterations", &OdometryLaserCalibrationSettings::outlier_iterations)
      .def_readwrite("outlier_quantile", &OdometryLaserCalibrationSettings::outlier_quantile)
      .def_readwrite("max_condition_number", &OdometryLaserCalibrationSettings::max_condition_number)
      .def_readwrite("min_tuples", &OdometryLaserCalibrationSettings::min_tuples);
  py::class_<OdometryLaserCalibrationResult>(
      m, "OdometryLaserCalibrationResult",
      "params: (radius_left, radius_right, axle, laser x, laser y, laser theta) as a (6,) array; covariance 6x6 "
      "over the same.")
      .def_readonly("status", &OdometryLaserCalibrationResult::status)
      .def_property_readonly("params", [](const OdometryLaserCalibrationResult& r) { return r.params.vector(); })
      .def_readonly("covariance", &OdometryLaserCalibrationResult::covariance)
      .def_readonly("laser_noise_std", &OdometryLaserCalibrationResult::laser_noise_std)
      .def_readonly("num_tuples", &OdometryLaserCalibrationResult::num_tuples)
      .def_readonly("num_inliers", &OdometryLaserCalibrationResult::num_inliers)
      .def_readonly("inlier", &OdometryLaserCalibrationResult::inlier)
      .def_readonly("solves", &OdometryLaserCalibrationResult::solves)
      .def_readonly("condition_number", &OdometryLaserCalibrationResult::condition_number);
  m.def(
      "read_calib_tuples",
      [](const std::filesystem::path& path) {
        return table_to_array(io::read_calib_tuples(path.string()), 6, [](const CalibrationTuple& t, double* row) {
          row[0] = t.T;
          row[1] = t.phi_left;
          row[2] = t.phi_right;
          row[3] = t.laser_motion.x;
          row[4] = t.laser_motion.y;
          row[5] = t.laser_motion.theta;
        });
      },
      py::arg("path"),
      "Calibration tuples (Censi's JSON lines) as an (N, 6) float64 array: T, phi_left, phi_right, laser motion x, "
      "y, theta.");
  m.def(
      "calibrate_odometry_laser",
      [](const py::object& tuples, const py::kwargs& kwargs) {
        const auto settings = settings_from_kwargs<OdometryLaserCalibrationSettings>(kwargs, "calibrate_odometry_laser");
        const auto table = table_from_array(tuples, "calibrate_odometry_laser: tuples", 6);
        std::vector<CalibrationTuple> t(static_cast<std::size_t>(table.shape(0)));
        for (std::size_t i = 0; i < t.size(); ++i) {
          const double* row = table.data() + 6 * i;
          t[i] = CalibrationTuple{row[0], row[1], row[2], Pose2{row[3], row[4], row[5]}};
        }
        py::gil_scoped_release release;
        return calibrate_odometry_laser(t, settings);
      },
      py::arg("tuples"),
      "Wheel radii, axle and laser pose from (N, 6) calibration tuples (Censi et al. T-RO 2013), what `plumb "
      "calibrate` does. Keyword arguments: the fields of OdometryLaserCalibrationSettings.");
}

}  // namespace

void bind_scan2d(py::module_& m) {
  bind_laser_scan(m);
  bind_plicp(m);
  bind_calibration(m);
}

}  // namespace plumb::python
