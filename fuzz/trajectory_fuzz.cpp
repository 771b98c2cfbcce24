// SPDX-License-Identifier: BSD-3-Clause
// libFuzzer target for the trajectory readers: the same bytes go to parse_tum, parse_kitti and
// parse_times (each rejects the others' lines by their field count, so one corpus serves all
// three). Each must either return a consistent result or throw plumb::Error.
// Seeds: $PLUMB_DATA_DIR/trajectories/kitti00 (scripts/test.sh) and fuzz/seeds/trajectory.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "plumb/core/error.hpp"
#include "plumb/io/trajectory.hpp"

#include "fuzz_require.hpp"

// Names this target in the messages of FUZZ_REQUIRE.
constexpr const char* kFuzzTarget = "trajectory_fuzz";

namespace {

// Rotation blocks are within the readers' default tolerance (1e-3) of SO(3), or exact after
// normalization / orthonormalization.
bool is_rotation(const Eigen::Matrix3d& R, double tolerance) {
  return R.allFinite() && (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() <= tolerance &&
         R.determinant() > 0.0;
}

void check(const plumb::Trajectory& t, bool stamps, double tolerance) {
  t.check_consistent("trajectory_fuzz");
  FUZZ_REQUIRE(!t.empty());
  FUZZ_REQUIRE(t.has_stamps() == stamps);
  for (double s : t.stamps) FUZZ_REQUIRE(std::isfinite(s));
  for (const Eigen::Isometry3d& T : t.poses) {
    FUZZ_REQUIRE(T.translation().allFinite());
    FUZZ_REQUIRE(is_rotation(T.linear(), tolerance));
    FUZZ_REQUIRE((T.matrix().row(3) - Eigen::RowVector4d(0, 0, 0, 1)).isZero(0.0));
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    check(plumb::io::parse_tum(text, "fuzz.tum"), true, 1e-9);
  } catch (const plumb::Error&) {
  }
  try {
    check(plumb::io::parse_kitti(text, "fuzz.txt"), false, 1e-9);
  } catch (const plumb::Error&) {
  }
  try {
    plumb::io::TrajectoryReadSettings as_printed;
    as_printed.orthonormalize = false;
    check(plumb::io::parse_kitti(text, "fuzz.txt", as_printed), false, 1e-3);
  } catch (const plumb::Error&) {
  }
  try {
    const std::vector<double> stamps = plumb::io::parse_times(text, "fuzz_times.txt");
    FUZZ_REQUIRE(!stamps.empty());
    for (double s : stamps) FUZZ_REQUIRE(std::isfinite(s));
  } catch (const plumb::Error&) {
  }
  return 0;
}
