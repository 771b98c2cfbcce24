// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#define PLUMB_VERSION_MAJOR 0
#define PLUMB_VERSION_MINOR 1
#define PLUMB_VERSION_PATCH 0
#define PLUMB_VERSION_STRING "0.1.0"

namespace plumb {
/// @brief The library's version string ("major.minor.patch"), as compiled into the binary.
const char* version();
}  // namespace plumb
