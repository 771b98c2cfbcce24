// SPDX-License-Identifier: BSD-3-Clause
// Links plumb::core only (Eigen and nothing else): voxel grid, kd-tree and ICP on a synthetic
// corner, which ICP must bring back from a known offset.
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <random>

#include <plumb/filters/voxel_grid.hpp>
#include <plumb/registration/icp.hpp>
#include <plumb/search/kdtree.hpp>

int main() {
  // Three perpendicular 2 m x 2 m walls, points drawn at random (a regular grid would give ICP
  // false minima one grid step apart): a corner fixes all six degrees of freedom.
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(0.0f, 2.0f);
  plumb::PointCloud target;
  for (int i = 0; i < 10000; ++i) {
    target.points.emplace_back(u(rng), u(rng), 0.0f);
    target.points.emplace_back(u(rng), 0.0f, u(rng));
    target.points.emplace_back(0.0f, u(rng), u(rng));
  }
  plumb::VoxelGridSettings voxel;
  voxel.leaf_size = 0.05;
  const plumb::PointCloud down = plumb::voxel_grid(target, voxel).cloud;
  const bool voxel_ok = down.size() > 3000 && down.size() < target.size() / 2;  // ~4800 voxels of 5 cm

  const plumb::KdTree3f tree(target);
  const plumb::Vector3f query(0.3f, 1.1f, 0.05f);
  const auto nearest = tree.nearest(query);
  std::size_t brute = 0;  // the nearest point by brute force
  for (std::size_t i = 1; i < target.size(); ++i) {
    if ((target.points[i] - query).squaredNorm() < (target.points[brute] - query).squaredNorm()) brute = i;
  }
  const bool tree_ok = nearest && nearest->index == brute;

  Eigen::Isometry3d offset = Eigen::Isometry3d::Identity();
  offset.translation() = Eigen::Vector3d(0.03, -0.02, 0.04);
  offset.linear() = Eigen::AngleAxisd(0.02, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  plumb::PointCloud source;
  for (std::size_t i = 0; i < target.size(); i += 5) {  // a fifth of the target's own points, moved
    source.points.push_back((offset.inverse() * target.points[i].cast<double>()).cast<float>());
  }
  const plumb::IcpResult icp = plumb::align_icp(source, target, Eigen::Isometry3d::Identity());
  const double error = (icp.T_target_source.translation() - offset.translation()).norm();
  const bool icp_ok = icp.status == plumb::Status::kOk && error < 5e-3;

  std::printf("plumb::core: voxel grid %s, kd-tree %s, icp %s (%.2g m)\n", voxel_ok ? "ok" : "FAILED",
              tree_ok ? "ok" : "FAILED", icp_ok ? "ok" : "FAILED", error);
  return voxel_ok && tree_ok && icp_ok ? 0 : 1;
}
