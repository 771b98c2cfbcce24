// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/version.hpp"

namespace plumb {

const char* version() { return PLUMB_VERSION_STRING; }

}  // namespace plumb
