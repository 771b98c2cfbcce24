// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Where the source, build and data trees are, for the tests and the benchmarks (no gtest).
///
/// No path is compiled into a test or benchmark object: the build tree is where the binary lies
/// (two levels up: tests/<binary>, bench/<binary>), the source tree and the data directory are in
/// that tree's CMakeCache.txt, and each can be overridden by the environment variable of its name
/// (ctest sets PLUMB_DATA_DIR, tests/CMakeLists.txt). The objects of two clones are then the same,
/// and a compiler cache built for one serves the other.

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <system_error>

namespace plumb::test {

/// @brief The build tree: PLUMB_BINARY_DIR, else two levels above this binary.
inline std::string binary_dir() {
  if (const char* env = std::getenv("PLUMB_BINARY_DIR"); env != nullptr && *env != '\0') return env;
  std::error_code ec;
  const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  return ec ? std::string(".") : exe.parent_path().parent_path().string();
}

/// @brief A value of binary_dir()/CMakeCache.txt (`KEY:TYPE=value`), empty when absent.
inline std::string cmake_cache_value(const std::string& key) {
  std::ifstream in(binary_dir() + "/CMakeCache.txt");
  for (std::string line; std::getline(in, line);) {
    const std::size_t colon = line.find(':'), eq = line.find('=');
    if (colon == key.size() && line.compare(0, key.size(), key) == 0 && eq != std::string::npos) {
      return line.substr(eq + 1);
    }
  }
  return "";
}

/// @brief The source tree: PLUMB_SOURCE_DIR, else the build tree's CMake cache.
inline std::string source_dir() {
  if (const char* env = std::getenv("PLUMB_SOURCE_DIR"); env != nullptr && *env != '\0') return env;
  return cmake_cache_value("plumb_SOURCE_DIR");
}

/// @brief The shared data: PLUMB_DATA_DIR, else the CMake cache variable of the same name.
inline std::string data_dir() {
  if (const char* env = std::getenv("PLUMB_DATA_DIR"); env != nullptr && *env != '\0') return env;
  return cmake_cache_value("PLUMB_DATA_DIR");
}

}  // namespace plumb::test
