// SPDX-License-Identifier: BSD-3-Clause
// Builds against an installed plumb through find_package(plumb) and checks a few results.
#include <cmath>
#include <cstdio>

#include <plumb/plumb.hpp>

int main() {
  plumb::PointCloud cloud;
  cloud.points = {{0.f, 0.f, 0.f}, {1.f, 0.f, 0.f}, {0.f, 2.f, 0.f}};
  const plumb::Pose2 a{1.0, 2.0, 0.5};
  const plumb::Pose2 round_trip = a.oplus(a.ominus());
  const bool pose_ok = std::abs(round_trip.x) < 1e-12 && std::abs(round_trip.y) < 1e-12;
  std::printf("plumb %s: %zu points, pose round trip %s\n", PLUMB_VERSION_STRING, cloud.size(),
              pose_ok ? "ok" : "FAILED");
  return pose_ok ? 0 : 1;
}
