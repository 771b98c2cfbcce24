// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <sstream>
#include <stdexcept>
#include <string>

namespace plumb {

/// @brief The one exception type plumb throws: misuse of an API or input that cannot be read.
/// @note The message names the input and the place (`file.pcd:12: ...`, `align_icp: empty target`).
///       Algorithms that merely fail to converge return a Status instead of throwing.
class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& what) : std::runtime_error(what) {}
};

namespace detail {
[[noreturn]] inline void throw_check_failure(const char* condition, const char* file, int line,
                                             const std::string& message) {
  // A message names the input and the place in it, which is what a user needs; the source
  // location is added only for a bare check, where it is the only clue.
  if (!message.empty()) throw Error(message);
  std::ostringstream os;
  os << "check failed: " << condition << " [" << file << ':' << line << ']';
  throw Error(os.str());
}
}  // namespace detail

}  // namespace plumb

/// @brief Throw plumb::Error with a streamed message when `cond` is false.
/// Usage: `PLUMB_CHECK(!cloud.empty(), "voxel_grid: empty input cloud");`
///        `PLUMB_CHECK(n > 0, path << ":" << line << ": bad count " << n);`
#define PLUMB_CHECK(cond, msg)                                                              \
  do {                                                                                      \
    if (!(cond)) {                                                                          \
      std::ostringstream plumb_check_os_;                                                   \
      plumb_check_os_ << msg;                                                               \
      ::plumb::detail::throw_check_failure(#cond, __FILE__, __LINE__, plumb_check_os_.str()); \
    }                                                                                       \
  } while (false)

/// @brief Throw plumb::Error with a streamed message unconditionally.
#define PLUMB_THROW(msg)                                                     \
  do {                                                                       \
    std::ostringstream plumb_throw_os_;                                      \
    plumb_throw_os_ << msg;                                                  \
    throw ::plumb::Error(plumb_throw_os_.str());                             \
  } while (false)
