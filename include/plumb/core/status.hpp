// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <ostream>

namespace plumb {

/// @brief Outcome of an algorithm. Failure to converge is a Status, never an exception.
enum class Status {
  kOk,                 ///< converged and passed every gate
  kNotConverged,       ///< hit the iteration limit before the stopping criterion
  kInsufficientData,   ///< too few points / correspondences / inliers to estimate anything
  kDegenerate,         ///< geometry does not constrain the estimate (corridor, collinear points)
  kRejected,           ///< an estimate was found but failed a confidence gate (overlap, fitness)
  kInvalidInput,       ///< input violates a precondition the algorithm can report instead of throw
};

/// @brief Stable lower-case name of a status ("ok", "not_converged", ...), for logs and JSON.
inline const char* to_string(Status s) {
  switch (s) {
    case Status::kOk: return "ok";
    case Status::kNotConverged: return "not_converged";
    case Status::kInsufficientData: return "insufficient_data";
    case Status::kDegenerate: return "degenerate";
    case Status::kRejected: return "rejected";
    case Status::kInvalidInput: return "invalid_input";
  }
  return "unknown";
}

inline std::ostream& operator<<(std::ostream& os, Status s) { return os << to_string(s); }

}  // namespace plumb
