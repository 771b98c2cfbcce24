// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Helpers shared by the cloud reader/writer tests: bit-exact cloud comparison and
/// "throws plumb::Error naming these things".

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "plumb/core/error.hpp"
#include "plumb/core/point_cloud.hpp"
#include "test_data.hpp"

namespace plumb::test {

/// @brief Expect plumb::Error whose message contains every fragment.
template <class Fn>
void expect_error(Fn&& fn, const std::vector<std::string>& fragments) {
  try {
    fn();
    ADD_FAILURE() << "expected plumb::Error";
  } catch (const Error& e) {
    const std::string msg = e.what();
    for (const auto& f : fragments) EXPECT_NE(msg.find(f), std::string::npos) << "'" << f << "' not in: " << msg;
  }
}

/// @brief Bit-exact float equality (distinguishes -0), with NaN equal to NaN.
inline bool same_float(float a, float b) {
  if (std::isnan(a) || std::isnan(b)) return std::isnan(a) && std::isnan(b);
  return std::memcmp(&a, &b, sizeof(float)) == 0;
}

/// @brief Two clouds hold the same fields with bit-identical values.
inline void expect_same_cloud(const PointCloud& a, const PointCloud& b) {
  ASSERT_EQ(a.size(), b.size());
  ASSERT_EQ(a.normals.size(), b.normals.size());
  ASSERT_EQ(a.intensities.size(), b.intensities.size());
  ASSERT_EQ(a.rings.size(), b.rings.size());
  ASSERT_EQ(a.times.size(), b.times.size());
  ASSERT_EQ(a.labels.size(), b.labels.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    for (int k = 0; k < 3; ++k) {
      ASSERT_TRUE(same_float(a.points[i][k], b.points[i][k])) << "point " << i << " coord " << k;
      if (a.has_normals()) {
        ASSERT_TRUE(same_float(a.normals[i][k], b.normals[i][k])) << "normal " << i;
      }
    }
    if (a.has_intensities()) {
      ASSERT_TRUE(same_float(a.intensities[i], b.intensities[i])) << "intensity " << i;
    }
    if (a.has_times()) {
      ASSERT_TRUE(same_float(a.times[i], b.times[i])) << "time " << i;
    }
    if (a.has_rings()) {
      ASSERT_EQ(a.rings[i], b.rings[i]) << "ring " << i;
    }
    if (a.has_labels()) {
      ASSERT_EQ(a.labels[i], b.labels[i]) << "label " << i;
    }
  }
}

/// @brief n random points with every optional field set, coordinates uniform in [-scale, scale];
/// the caller plants its own awkward values (NaN, -0, extremes) on top.
inline PointCloud random_full_cloud(std::size_t n, unsigned seed, float scale, float time_scale) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-scale, scale);
  PointCloud c;
  for (std::size_t i = 0; i < n; ++i) {
    c.points.emplace_back(u(rng), u(rng), u(rng));
    c.normals.emplace_back(u(rng) / scale, u(rng) / scale, u(rng) / scale);
    c.intensities.push_back(u(rng) + scale);
    c.rings.push_back(static_cast<std::uint16_t>(rng() % 65536));
    c.times.push_back(u(rng) * time_scale);
    c.labels.push_back(static_cast<std::int32_t>(rng()));
  }
  return c;
}

/// @brief A round trip through a scratch file (temp_path(name)): `write(path, c, settings)` writes
///        `c`, `read(path)` must give it back bit-exact; the file is removed after.
template <class Settings, class Write, class Read>
void expect_file_round_trip(const PointCloud& c, const Settings& settings, const std::string& name, Write&& write,
                            Read&& read) {
  const std::string file = temp_path(name);
  write(file, c, settings);
  expect_same_cloud(c, read(file));
  std::remove(file.c_str());
}

}  // namespace plumb::test

namespace plumb::io {

// The helpers above by their short names in the reader and writer tests, which live in plumb::io.
using test::expect_error;
using test::expect_file_round_trip;
using test::expect_same_cloud;
using test::same_float;

}  // namespace plumb::io
