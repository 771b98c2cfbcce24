// SPDX-License-Identifier: BSD-3-Clause
// The one instantiation of each Eigen decomposition declared extern in
// plumb/core/impl/eigen_instantiations.hpp (compiled whether or not the build uses the externs).
#define PLUMB_EIGEN_INSTANTIATIONS_DEFINE
#include "plumb/core/impl/eigen_instantiations.hpp"

PLUMB_EIGEN_INSTANTIATIONS(template)
