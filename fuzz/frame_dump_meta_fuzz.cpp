// SPDX-License-Identifier: BSD-3-Clause
// libFuzzer target for a frame dump's meta.json: parse_frame_dump_meta must either return a
// consistent FrameDumpMeta or throw plumb::Error, and what it returns must survive the writer
// (frame_dump_meta_json) and a second parse unchanged.
// Seeds: fuzz/seeds/frame_dump_meta/*.json.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "plumb/core/error.hpp"
#include "plumb/io/frame_dump.hpp"

#include "fuzz_require.hpp"

// Names this target in the messages of FUZZ_REQUIRE.
constexpr const char* kFuzzTarget = "frame_dump_meta_fuzz";

namespace {

bool is_rigid(const Eigen::Isometry3d& T) {
  const Eigen::Matrix3d R = T.linear();
  return T.matrix().allFinite() &&
         (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() < 1e-9 && R.determinant() > 0.0;
}

bool same_number(double a, double b) { return a == b && std::signbit(a) == std::signbit(b); }

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  plumb::io::FrameDumpMeta meta;
  try {
    meta = plumb::io::parse_frame_dump_meta(text, "fuzz/meta.json");
  } catch (const plumb::Error&) {
    return 0;
  }
  FUZZ_REQUIRE(is_rigid(meta.T_base_lidar) && is_rigid(meta.T_base_imu));
  FUZZ_REQUIRE(meta.lidar.columns >= 0);
  FUZZ_REQUIRE(meta.wheel_radius_left >= 0.0 && meta.wheel_radius_right >= 0.0 && meta.axle >= 0.0);
  FUZZ_REQUIRE(meta.imu_rate_hz >= 0.0 && meta.origin_offset.allFinite());
  for (double e : meta.lidar.elevations_rad) FUZZ_REQUIRE(std::isfinite(e));

  // What the writer makes of it reads back to the same values (rotations up to rounding).
  plumb::io::FrameDumpMeta again;
  try {
    again = plumb::io::parse_frame_dump_meta(plumb::io::frame_dump_meta_json(meta), "fuzz/rewritten.json");
  } catch (const plumb::Error& e) {
    std::fprintf(stderr, "frame_dump_meta_fuzz: the writer's output does not parse: %s\n", e.what());
    std::abort();
  }
  FUZZ_REQUIRE(again.lidar.name == meta.lidar.name && again.source == meta.source &&
               again.model == meta.model && again.scenario == meta.scenario);
  FUZZ_REQUIRE(again.lidar.columns == meta.lidar.columns);
  FUZZ_REQUIRE(same_number(again.lidar.rate_hz, meta.lidar.rate_hz) &&
               same_number(again.lidar.min_range, meta.lidar.min_range) &&
               same_number(again.lidar.max_range, meta.lidar.max_range));
  FUZZ_REQUIRE(again.lidar.elevations_rad == meta.lidar.elevations_rad);
  FUZZ_REQUIRE(same_number(again.wheel_radius_left, meta.wheel_radius_left) &&
               same_number(again.wheel_radius_right, meta.wheel_radius_right) &&
               same_number(again.axle, meta.axle) && same_number(again.imu_rate_hz, meta.imu_rate_hz));
  FUZZ_REQUIRE(again.origin_offset == meta.origin_offset);
  FUZZ_REQUIRE(again.T_base_lidar.translation() == meta.T_base_lidar.translation());
  FUZZ_REQUIRE(again.T_base_imu.translation() == meta.T_base_imu.translation());
  FUZZ_REQUIRE((again.T_base_lidar.linear() - meta.T_base_lidar.linear()).cwiseAbs().maxCoeff() < 1e-12);
  FUZZ_REQUIRE((again.T_base_imu.linear() - meta.T_base_imu.linear()).cwiseAbs().maxCoeff() < 1e-12);
  return 0;
}
