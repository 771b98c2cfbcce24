// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/io/input_file.hpp"

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <system_error>

#include "plumb/core/error.hpp"

namespace plumb::io {

void check_input_file(const std::string& path) {
  PLUMB_CHECK(!path.empty(), "input file name is empty");
  std::error_code ec;
  const std::filesystem::file_status status = std::filesystem::status(path, ec);
  PLUMB_CHECK(status.type() != std::filesystem::file_type::not_found, path << ": no such file");
  PLUMB_CHECK(status.type() != std::filesystem::file_type::directory,
              path << ": is a directory, not a file");
  std::ifstream in(path, std::ios::binary);
  PLUMB_CHECK(in.is_open(), path << ": cannot open file (" << std::strerror(errno) << ")");
}

std::ifstream open_input_file(const std::string& path) {
  check_input_file(path);
  std::ifstream in(path, std::ios::binary);
  PLUMB_CHECK(in.is_open(), path << ": cannot open file (" << std::strerror(errno) << ")");
  return in;
}

}  // namespace plumb::io
