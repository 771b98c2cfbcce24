// SPDX-License-Identifier: BSD-3-Clause
// Links plumb::pipeline: the pose composer chains two motions and an anchor pulls the pose to it.
#include <cmath>
#include <cstdio>

#include <plumb/pipeline/pose_composer.hpp>

int main() {
  plumb::PoseComposer composer(Eigen::Isometry3d::Identity(), plumb::Matrix6d::Identity() * 1e-6);
  Eigen::Isometry3d step = Eigen::Isometry3d::Identity();
  step.translation() = Eigen::Vector3d(1.0, 0.0, 0.0);
  composer.add_motion(step, plumb::Matrix6d::Identity() * 1e-4);
  composer.add_motion(step, plumb::Matrix6d::Identity() * 1e-4);
  const bool chained = (composer.pose().translation() - Eigen::Vector3d(2.0, 0.0, 0.0)).norm() < 1e-12;
  Eigen::Isometry3d measured = composer.pose();
  measured.translation().y() = 0.01;  // within the chain's uncertainty (gated otherwise)
  composer.add_anchor(measured, plumb::Matrix6d::Identity() * 1e8);  // far more certain than the chain
  const bool anchored = std::abs(composer.pose().translation().y() - 0.01) < 1e-4;
  std::printf("plumb::pipeline: pose composer %s\n", chained && anchored ? "ok" : "FAILED");
  return chained && anchored ? 0 : 1;
}
