// SPDX-License-Identifier: BSD-3-Clause
// Builds against an installed plumb through find_package(plumb) and checks a few results, touching
// the header-only core, a compiled module (PCD I/O with LZF) and the templates (kd-tree, voxel grid).
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>

#include <plumb/plumb.hpp>

int main() {
  plumb::PointCloud cloud;
  for (int i = 0; i < 1000; ++i) {
    cloud.points.emplace_back(0.01f * static_cast<float>(i % 10), 0.01f * static_cast<float>((i / 10) % 10),
                              0.01f * static_cast<float>(i / 100));
  }
  const plumb::Pose2 a{1.0, 2.0, 0.5};
  const plumb::Pose2 round_trip = a.oplus(a.ominus());
  const bool pose_ok = std::abs(round_trip.x) < 1e-12 && std::abs(round_trip.y) < 1e-12;

  plumb::VoxelGridSettings voxel;
  voxel.leaf_size = 0.05;
  const plumb::VoxelGridResult down = plumb::voxel_grid(cloud, voxel);
  const bool voxel_ok = down.cloud.size() == 8;  // a 0.1 m cube of 1 cm points in 5 cm voxels

  const plumb::KdTree3f tree(cloud);
  const auto nearest = tree.nearest(plumb::Vector3f(0.0f, 0.0f, 0.0f));
  const bool tree_ok = nearest && nearest->index == 0;

  const std::string path =
      (std::filesystem::temp_directory_path() / "plumb_consumer_roundtrip.pcd").string();
  plumb::io::PcdWriteSettings pcd;
  pcd.encoding = plumb::io::PcdEncoding::kBinaryCompressed;
  plumb::io::write_pcd(path, cloud, pcd);
  const bool io_ok = plumb::io::read_pcd(path).size() == cloud.size();

  std::printf("plumb %s: pose %s, voxel grid %s, kd-tree %s, pcd %s\n", plumb::version(),
              pose_ok ? "ok" : "FAILED", voxel_ok ? "ok" : "FAILED", tree_ok ? "ok" : "FAILED",
              io_ok ? "ok" : "FAILED");
  return pose_ok && voxel_ok && tree_ok && io_ok ? 0 : 1;
}
