// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Locating the shared real data (see shared/data/SOURCES.md) from tests.
///
/// The directory is the environment variable PLUMB_DATA_DIR when set, else the CMake cache variable
/// of the same name. A test that needs a file calls PLUMB_REQUIRE_DATA(path), which
/// skips the test with a message when the file is missing (the CI script makes a missing data
/// directory an error before any test runs).

#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "build_tree.hpp"

namespace plumb::test {

/// @brief Absolute path of a file under the data directory, e.g. data_path("cloud3d/pcl_test/bun0.pcd").
inline std::string data_path(const std::string& relative) { return data_dir() + "/" + relative; }

inline bool file_exists(const std::string& path) { return std::ifstream(path).good(); }

/// @brief A fresh scratch directory path under the build tree for files a test writes.
inline std::string temp_path(const std::string& name) { return binary_dir() + "/test_tmp_" + name; }

}  // namespace plumb::test

/// @brief Declare `const std::string var` = data_path(relative), skipping the test if it is missing.
#define PLUMB_REQUIRE_DATA(var, relative)                                                   \
  const std::string var = ::plumb::test::data_path(relative);                               \
  if (!::plumb::test::file_exists(var)) {                                                   \
    GTEST_SKIP() << "test data not found: " << var << " (set PLUMB_DATA_DIR)";              \
  }
