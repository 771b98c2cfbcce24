// SPDX-License-Identifier: BSD-3-Clause
#include "convert.hpp"

#include <cmath>
#include <cstring>
#include <limits>
#include <sstream>

namespace plumb::python {
namespace {

/// The object as a numpy array (np.asarray), or ValueError.
py::array as_array(const py::handle& obj, const char* what, const char* expected) {
  py::array arr = py::array::ensure(obj);
  if (!arr) {
    PyErr_Clear();
    throw py::value_error(std::string(what) + ": expected " + expected + ", got an object of type " +
                          py::str(py::type::of(obj).attr("__name__")).cast<std::string>());
  }
  return arr;
}

[[noreturn]] void throw_bad_array(const py::array& arr, const char* what, const char* expected) {
  std::ostringstream os;
  os << what << ": expected " << expected << ", got an array of shape "
     << py::str(arr.attr("shape")).cast<std::string>() << " and dtype " << py::str(arr.dtype()).cast<std::string>();
  throw py::value_error(os.str());
}

bool is_float32_or_64(const py::array& arr) {
  return arr.dtype().kind() == 'f' && (arr.itemsize() == 4 || arr.itemsize() == 8);
}

/// A float32/float64 array of `ndim` dimensions whose trailing sizes are `tail` (-1: any), as a
/// C-contiguous array of T; ValueError otherwise.
template <typename T>
py::array_t<T, py::array::c_style | py::array::forcecast> float_array(const py::handle& obj, const char* what,
                                                                       const char* expected, py::ssize_t ndim,
                                                                       std::vector<py::ssize_t> tail) {
  const py::array arr = as_array(obj, what, expected);
  bool ok = is_float32_or_64(arr) && arr.ndim() == ndim;
  for (std::size_t i = 0; ok && i < tail.size(); ++i) {
    ok = tail[i] < 0 || arr.shape(static_cast<py::ssize_t>(ndim - static_cast<py::ssize_t>(tail.size()) +
                                                           static_cast<py::ssize_t>(i))) == tail[i];
  }
  if (!ok) throw_bad_array(arr, what, expected);
  return py::array_t<T, py::array::c_style | py::array::forcecast>::ensure(arr);
}

template <typename Vec, typename T>
std::vector<Vec> rows_from_array(const py::handle& obj, const char* what) {
  const auto arr = float_array<T>(obj, what, "an (N, 3) float32 or float64 array", 2, {3});
  std::vector<Vec> out(static_cast<std::size_t>(arr.shape(0)));
  const T* data = arr.data();
  for (std::size_t i = 0; i < out.size(); ++i) out[i] = Vec(data[3 * i], data[3 * i + 1], data[3 * i + 2]);
  return out;
}

}  // namespace

std::vector<Vector3f> points_from_array(const py::handle& obj, const char* what) {
  return rows_from_array<Vector3f, float>(obj, what);
}

std::vector<Vector3d> positions_from_array(const py::handle& obj, const char* what) {
  return rows_from_array<Vector3d, double>(obj, what);
}

Vector3f point_from_array(const py::handle& obj, const char* what) {
  const auto arr = float_array<float>(obj, what, "a (3,) float32 or float64 array", 1, {3});
  return Vector3f(arr.data()[0], arr.data()[1], arr.data()[2]);
}

py::array_t<float> points_to_array(const std::vector<Vector3f>& points) {
  py::array_t<float> out({static_cast<py::ssize_t>(points.size()), py::ssize_t{3}});
  float* dst = out.mutable_data();
  for (std::size_t i = 0; i < points.size(); ++i) {
    for (int a = 0; a < 3; ++a) dst[3 * i + static_cast<std::size_t>(a)] = points[i][a];
  }
  return out;
}

std::vector<float> floats_from_array(const py::handle& obj, const char* what) {
  const auto arr = float_array<float>(obj, what, "an (N,) float32 or float64 array", 1, {});
  return std::vector<float>(arr.data(), arr.data() + arr.shape(0));
}

std::vector<double> doubles_from_array(const py::handle& obj, const char* what) {
  const auto arr = float_array<double>(obj, what, "an (N,) float32 or float64 array", 1, {});
  return std::vector<double>(arr.data(), arr.data() + arr.shape(0));
}

template <typename Int>
std::vector<Int> ints_from_array(const py::handle& obj, const char* what) {
  const char* expected = "an (N,) integer array";
  const py::array arr = as_array(obj, what, expected);
  const char kind = arr.dtype().kind();
  if ((kind != 'i' && kind != 'u') || arr.ndim() != 1) throw_bad_array(arr, what, expected);
  const auto wide = py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>::ensure(arr);
  std::vector<Int> out(static_cast<std::size_t>(wide.shape(0)));
  for (std::size_t i = 0; i < out.size(); ++i) {
    const std::int64_t v = wide.data()[i];
    if (v < static_cast<std::int64_t>(std::numeric_limits<Int>::min()) ||
        v > static_cast<std::int64_t>(std::numeric_limits<Int>::max())) {
      std::ostringstream os;
      os << what << ": value " << v << " at index " << i << " is out of range [" << +std::numeric_limits<Int>::min()
         << ", " << +std::numeric_limits<Int>::max() << "]";
      throw py::value_error(os.str());
    }
    out[i] = static_cast<Int>(v);
  }
  return out;
}

template std::vector<std::uint16_t> ints_from_array<std::uint16_t>(const py::handle&, const char*);
template std::vector<std::int32_t> ints_from_array<std::int32_t>(const py::handle&, const char*);
template std::vector<std::int64_t> ints_from_array<std::int64_t>(const py::handle&, const char*);

template <typename T>
py::array vector_to_array(const std::vector<T>& values) {
  py::array_t<T> out(static_cast<py::ssize_t>(values.size()));
  if (!values.empty()) std::memcpy(out.mutable_data(), values.data(), values.size() * sizeof(T));
  return std::move(out);
}

template py::array vector_to_array<float>(const std::vector<float>&);
template py::array vector_to_array<double>(const std::vector<double>&);
template py::array vector_to_array<std::uint16_t>(const std::vector<std::uint16_t>&);
template py::array vector_to_array<std::int32_t>(const std::vector<std::int32_t>&);

py::array indices_to_array(const std::vector<std::size_t>& indices) {
  py::array_t<std::int64_t> out(static_cast<py::ssize_t>(indices.size()));
  for (std::size_t i = 0; i < indices.size(); ++i) out.mutable_data()[i] = static_cast<std::int64_t>(indices[i]);
  return std::move(out);
}

namespace {

Eigen::Isometry3d pose_from_data(const double* m, const char* what, std::size_t index, bool many) {
  Eigen::Matrix4d M;
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) M(r, c) = m[4 * r + c];
  }
  const bool last_row = std::abs(M(3, 0)) <= 1e-9 && std::abs(M(3, 1)) <= 1e-9 && std::abs(M(3, 2)) <= 1e-9 &&
                        std::abs(M(3, 3) - 1.0) <= 1e-9;
  if (!M.allFinite() || !last_row) {
    std::ostringstream os;
    os << what << ": " << (many ? "pose " + std::to_string(index) + " is not" : std::string("expected"))
       << " a rigid transform (finite 4x4 with last row 0 0 0 1)";
    throw py::value_error(os.str());
  }
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.matrix().topRows<3>() = M.topRows<3>();
  return T;
}

}  // namespace

Eigen::Isometry3d pose_from_array(const py::handle& obj, const char* what) {
  const auto arr = float_array<double>(obj, what, "a 4x4 float64 array", 2, {4, 4});
  return pose_from_data(arr.data(), what, 0, false);
}

py::array_t<double> pose_to_array(const Eigen::Isometry3d& pose) {
  py::array_t<double> out({py::ssize_t{4}, py::ssize_t{4}});
  double* dst = out.mutable_data();
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) dst[4 * r + c] = pose.matrix()(r, c);
  }
  return out;
}

std::vector<Eigen::Isometry3d> poses_from_array(const py::handle& obj, const char* what) {
  const auto arr = float_array<double>(obj, what, "an (N, 4, 4) float64 array", 3, {4, 4});
  std::vector<Eigen::Isometry3d> out;
  out.reserve(static_cast<std::size_t>(arr.shape(0)));
  for (std::size_t i = 0; i < static_cast<std::size_t>(arr.shape(0)); ++i) {
    out.push_back(pose_from_data(arr.data() + 16 * i, what, i, true));
  }
  return out;
}

py::array_t<double> poses_to_array(const std::vector<Eigen::Isometry3d>& poses) {
  py::array_t<double> out({static_cast<py::ssize_t>(poses.size()), py::ssize_t{4}, py::ssize_t{4}});
  double* dst = out.mutable_data();
  for (std::size_t i = 0; i < poses.size(); ++i) {
    for (int r = 0; r < 4; ++r) {
      for (int c = 0; c < 4; ++c) dst[16 * i + static_cast<std::size_t>(4 * r + c)] = poses[i].matrix()(r, c);
    }
  }
  return out;
}

Pose2 pose2_from_array(const py::handle& obj, const char* what) {
  const auto arr = float_array<double>(obj, what, "a (3,) float array (x, y, theta)", 1, {3});
  return Pose2{arr.data()[0], arr.data()[1], arr.data()[2]};
}

py::array_t<double> pose2_to_array(const Pose2& pose) {
  py::array_t<double> out(py::ssize_t{3});
  out.mutable_data()[0] = pose.x;
  out.mutable_data()[1] = pose.y;
  out.mutable_data()[2] = pose.theta;
  return out;
}

py::array_t<double, py::array::c_style | py::array::forcecast> table_from_array(const py::handle& obj,
                                                                                 const char* what, py::ssize_t cols) {
  const std::string expected = "an (N, " + std::to_string(cols) + ") float32 or float64 array";
  return float_array<double>(obj, what, expected.c_str(), 2, {cols});
}

PointCloud cloud_from_object(const py::handle& obj, const char* what) {
  if (py::isinstance<PointCloud>(obj)) return obj.cast<PointCloud>();
  PointCloud cloud;
  cloud.points = points_from_array(obj, what);
  return cloud;
}

}  // namespace plumb::python
