// SPDX-License-Identifier: BSD-3-Clause
#pragma once

// Shared pieces of the `plumb` subcommands: numeric option checks that reject NaN and infinity
// (CLI11's own PositiveNumber / Range let NaN through and print their bounds with 309 digits), the
// exit code of a job that ran to the end but failed, and errors that name the command's inputs.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdlib>
#include <iostream>
#include <limits>
#include <new>
#include <sstream>
#include <string>
#include <vector>

#include <sys/resource.h>

#include <CLI/CLI.hpp>

#include "plumb/core/error.hpp"
#include "plumb/io/stamps.hpp"

namespace plumb::cli {

/// Exit code of a subcommand that ran to the end and wrote its outputs, but whose result failed
/// (e.g. a registration that did not converge); see main.cpp for the whole scheme.
constexpr int kExitJobFailed = 3;

/// Thrown by a subcommand whose job ran but failed; main() prints the message and exits with
/// kExitJobFailed instead of 1.
class JobFailed : public plumb::Error {
 public:
  explicit JobFailed(const std::string& what) : plumb::Error(what) {}
};

/// Run a subcommand's work `f` on the files and directories `inputs` (empty names are ignored).
/// An error from deep inside the library often cannot know which file its data came from (a
/// voxel grid that would overflow, a cloud without extent, trajectories without a common stamp):
/// one whose message names none of the inputs is rethrown prefixed with them, "A, B: message", so
/// every failure names what the user gave. JobFailed keeps its type (and so its exit code).
template <class F>
void naming_inputs(const std::vector<std::string>& inputs, F&& f) {
  auto named = [&inputs](const std::string& what) {
    std::string prefix;
    for (std::size_t i = 0; i < inputs.size(); ++i) {
      const std::string& input = inputs[i];
      if (input.empty() || std::find(inputs.begin(), inputs.begin() + static_cast<std::ptrdiff_t>(i), input) !=
                               inputs.begin() + static_cast<std::ptrdiff_t>(i)) {
        continue;  // unset, or named already
      }
      if (what.find(input) != std::string::npos) return what;
      prefix += (prefix.empty() ? "" : ", ") + input;
    }
    return prefix.empty() ? what : prefix + ": " + what;
  };
  try {
    f();
  } catch (const JobFailed& e) {
    throw JobFailed(named(e.what()));
  } catch (const plumb::Error& e) {
    throw plumb::Error(named(e.what()));
  } catch (const std::bad_alloc&) {
    throw plumb::Error(named("out of memory (std::bad_alloc): the input asks for more than this machine has"));
  }
}

/// Peak resident set size of this process so far [MiB] (getrusage; Linux counts in KiB), for the
/// reports of the long-running commands: what a robot's computer must have free for the job.
inline double peak_rss_mib() {
  rusage usage{};
  if (getrusage(RUSAGE_SELF, &usage) != 0) return 0.0;
  return static_cast<double>(usage.ru_maxrss) / 1024.0;
}

/// A finite number in [lo, hi] (or (lo, hi] when `lo_open`); either bound may be infinite. CLI11
/// prefixes the message with the option's name. Integer options can use it too: CLI11 still
/// rejects a fraction when it converts the value.
inline CLI::Validator finite_number(double lo = -std::numeric_limits<double>::infinity(),
                                    double hi = std::numeric_limits<double>::infinity(), bool lo_open = false) {
  std::ostringstream description;
  description << "finite";
  if (std::isfinite(lo) && std::isfinite(hi)) {
    description << ' ' << (lo_open ? '(' : '[') << lo << ", " << hi << ']';
  } else if (std::isfinite(lo)) {
    description << (lo_open ? " > " : " >= ") << lo;
  } else if (std::isfinite(hi)) {
    description << " <= " << hi;
  }
  return CLI::Validator(
      [lo, hi, lo_open](std::string& input) -> std::string {
        const char* begin = input.c_str();
        char* end = nullptr;
        const double value = std::strtod(begin, &end);
        std::ostringstream message;
        if (end == begin || *end != '\0') {
          message << "'" << input << "' is not a number";
        } else if (!std::isfinite(value)) {  // also an overflow such as 1e400
          message << "'" << input << "' is not a finite number";
        } else if (lo_open ? !(value > lo) : !(value >= lo)) {
          message << input << " must be " << (lo_open ? "> " : ">= ") << lo;
        } else if (!(value <= hi)) {
          message << input << " must be <= " << hi;
        }
        return message.str();
      },
      description.str());
}

/// A finite number > 0 and <= hi.
inline CLI::Validator positive_number(double hi = std::numeric_limits<double>::infinity()) {
  return finite_number(0.0, hi, true);
}

/// A finite number >= 0 and <= hi.
inline CLI::Validator non_negative_number(double hi = std::numeric_limits<double>::infinity()) {
  return finite_number(0.0, hi, false);
}

}  // namespace plumb::cli

namespace plumb::cli {

/// The records of a log in message order with stamps that strictly increase (io::order_stamps):
/// a record whose stamp goes back in time is dropped, with a warning on stderr naming `path:line`
/// (the first few individually, then a count); runs of records sharing one stamp (a quantised
/// clock) are kept, their stamps spread evenly to the next one, with one warning. Laser logs do
/// carry both (a clock stepped back while logging, a logger writing coarse stamps); repairing them
/// keeps the log usable, where refusing it or dropping every tied record would not.
template <typename StampOf, typename LineOf>
io::StampOrder records_in_time_order(const std::string& path, std::size_t count, StampOf stamp_of,
                                     LineOf line_of, const char* what) {
  constexpr std::size_t kMaxWarnings = 5;
  std::vector<double> stamps(count);
  for (std::size_t k = 0; k < count; ++k) stamps[k] = stamp_of(k);
  io::StampOrder order = io::order_stamps(stamps);
  std::size_t shown = 0, kept_before = 0;
  for (std::size_t k : order.dropped) {
    if (++shown > kMaxWarnings) break;
    while (kept_before < order.kept.size() && order.kept[kept_before] < k) ++kept_before;
    const std::size_t last = order.kept[kept_before - 1];  // the first record is always kept
    std::ostringstream os;
    os.precision(15);
    os << "plumb: warning: " << path << ':' << line_of(k) << ": " << what << " stamp " << stamp_of(k)
       << " goes back before " << stamp_of(last) << " (line " << line_of(last) << "); " << what << " dropped\n";
    std::cerr << os.str();
  }
  if (order.dropped.size() > kMaxWarnings) {
    std::cerr << "plumb: warning: " << path << ": " << order.dropped.size() << ' ' << what
              << "s dropped in all because their stamps went back in time\n";
  }
  if (order.respread > 0) {
    std::cerr << "plumb: warning: " << path << ": " << order.respread << " of " << count << ' ' << what
              << "s share their stamp with the one before (a quantised clock?): kept in message order, their"
                 " stamps spread evenly up to the next one\n";
  }
  return order;
}

}  // namespace plumb::cli
