// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Where benchmarks find the shared data: env PLUMB_DATA_DIR, else the CMake cache value
/// compiled in (see shared/data/SOURCES.md).

#include <cstdlib>
#include <string>

namespace plumb::bench {

inline std::string data_dir() {
  if (const char* env = std::getenv("PLUMB_DATA_DIR"); env != nullptr && *env != '\0') return env;
#ifdef PLUMB_DATA_DIR
  return PLUMB_DATA_DIR;
#else
  return ".";
#endif
}

/// @brief Absolute path of a file under the data directory.
inline std::string data_path(const std::string& relative) { return data_dir() + "/" + relative; }

}  // namespace plumb::bench
