// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Running the built `plumb` binary (${PLUMB_BINARY_DIR}/examples/plumb) from tests, as a
/// user would: capture exit code, stdout and stderr.

#include <sys/wait.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <limits>
#include <string>

#include <gtest/gtest.h>

#include "test_data.hpp"

namespace plumb::test {

struct RunResult {
  int exit_code = -1;
  std::string out, err;
};

inline std::string read_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

inline std::string cli_binary() { return test::binary_dir() + "/examples/plumb"; }

/// @brief Run the built program PATH with ARGS (quoted by the caller), with per-test output files,
/// since ctest may run the tests of one binary in parallel.
inline RunResult run_program(const std::string& path, const std::string& args) {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  const std::string name = std::string(info->test_suite_name()) + "_" + info->name();
  const std::string out = temp_path("cli_" + name + "_stdout.txt");
  const std::string err = temp_path("cli_" + name + "_stderr.txt");
  const std::string command = "'" + path + "' " + args + " >'" + out + "' 2>'" + err + "'";
  const int status = std::system(command.c_str());
  RunResult r;
  if (status != -1 && WIFEXITED(status)) r.exit_code = WEXITSTATUS(status);
  r.out = read_text(out);
  r.err = read_text(err);
  return r;
}

/// @brief Run `plumb ARGS` (ARGS quoted by the caller).
inline RunResult run_cli(const std::string& args) { return run_program(cli_binary(), args); }

/// @brief The number after "key": inside the JSON object that is the value of "object" (the whole
/// text when `object` is empty). Enough for flat objects; NaN when absent.
inline double json_number(const std::string& text, const std::string& object, const std::string& key) {
  std::size_t begin = 0, end = text.size();
  if (!object.empty()) {
    begin = text.find("\"" + object + "\":");
    if (begin == std::string::npos) return std::numeric_limits<double>::quiet_NaN();
    begin = text.find('{', begin);
    end = text.find('}', begin);
  }
  const std::size_t k = text.find("\"" + key + "\"", begin);
  if (k == std::string::npos || k > end) return std::numeric_limits<double>::quiet_NaN();
  return std::strtod(text.c_str() + text.find(':', k) + 1, nullptr);
}

/// @brief Fixture that fails (not skips) when the CLI was not built: the CLI tests depend on it.
class CliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(file_exists(cli_binary())) << "plumb CLI not built: " << cli_binary();
  }
};

}  // namespace plumb::test
