// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Opening an input file with a message that names it and says what is wrong: readers that
///        just construct a std::ifstream accept a directory on Linux and then report it as an
///        empty or malformed file.

#include <fstream>
#include <string>

namespace plumb::io {

/// @brief Throw plumb::Error unless `path` names a regular file (or a device or pipe) that can be
///        opened for reading: `<path>: no such file`, `<path>: is a directory`,
///        `<path>: cannot open file (<reason>)`.
void check_input_file(const std::string& path);

/// @brief check_input_file(), then the file opened in binary mode.
std::ifstream open_input_file(const std::string& path);

}  // namespace plumb::io
