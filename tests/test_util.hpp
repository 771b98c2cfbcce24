// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Small helpers shared by the tests: the message of an expected error, a text file written
/// as given, and a turning, rising reference path.

#include <cmath>
#include <fstream>
#include <string>

#include "plumb/core/error.hpp"
#include "plumb/core/lie.hpp"
#include "plumb/core/trajectory.hpp"

namespace plumb::test {

/// The message of the plumb::Error `fn` throws, or "" when it throws nothing.
template <typename Fn>
std::string error_of(Fn&& fn) {
  try {
    fn();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

/// Write `text` to `path` byte for byte (binary mode: no newline translation).
inline void write_text(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
}

/// A turning path (a circle arc of radius 5 m rising in z) with 10 Hz stamps from 100 s, each
/// times `stamp_scale`: alignable in SE(3) and Sim(3).
inline Trajectory circle_trajectory(int n, double stamp_scale = 1.0) {
  Trajectory t;
  for (int i = 0; i < n; ++i) {
    const double a = 0.05 * i;
    t.push_back((100.0 + 0.1 * i) * stamp_scale,
                se3::make(so3::exp(Vector3d(0, 0, a)), Vector3d(5 * std::cos(a), 5 * std::sin(a), 0.01 * i)));
  }
  return t;
}

}  // namespace plumb::test
