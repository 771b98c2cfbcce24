// SPDX-License-Identifier: BSD-3-Clause
// The compiled part of the `plumb` Python package (plumb._plumb).
#include "convert.hpp"

#ifndef PLUMB_PYTHON_VERSION
#error "PLUMB_PYTHON_VERSION (the project version) must be defined by the build"
#endif

PYBIND11_MODULE(_plumb, m) {
  m.doc() = "plumb: BIM-anchored LiDAR odometry (Python bindings of the C++ library)";
  m.attr("__version__") = PLUMB_PYTHON_VERSION;
  plumb::python::bind_core(m);
  plumb::python::bind_io(m);
  plumb::python::bind_algorithms(m);
  plumb::python::bind_registration(m);
  plumb::python::bind_eval(m);
  plumb::python::bind_dump(m);
  plumb::python::bind_bim(m);
  plumb::python::bind_pipeline(m);
  plumb::python::bind_app(m);
  plumb::python::bind_features(m);
  plumb::python::bind_scan2d(m);
}
