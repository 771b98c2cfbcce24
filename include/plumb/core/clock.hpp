// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Wall time of a piece of work, for the `seconds` fields of results and reports.

#include <chrono>

namespace plumb {

/// @brief Seconds of steady-clock time since `t0`.
inline double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace plumb
