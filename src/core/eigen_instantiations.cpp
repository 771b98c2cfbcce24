// SPDX-License-Identifier: BSD-3-Clause
// The one instantiation of each Eigen decomposition declared extern in
// src/core/eigen_instantiations.hpp (compiled whether or not the build uses the externs).
#define PLUMB_EIGEN_INSTANTIATIONS_DEFINE
#include "core/eigen_instantiations.hpp"

// Instantiating whole classes compiles members no plumb code calls; GCC 12 -O3 then reports a false
// maybe-uninitialized inside Eigen's own code (ConditionEstimator). Not plumb's code to fix.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif
PLUMB_EIGEN_INSTANTIATIONS(template)
PLUMB_EIGEN_TRIDIAGONAL_INSTANTIATIONS(template)
