// SPDX-License-Identifier: BSD-3-Clause
// Example 01: the everyday pieces of plumb on a small synthetic room scan.
//   1. make a cloud (a 6 x 4 x 2.8 m room seen from its middle, 3 mm range noise, a few NaN returns)
//   2. voxel-downsample it at 5 cm, keeping per voxel the real point nearest the centroid (Liu et al. 2022, sec. 1.2)
//   3. build a kd-tree and ask for the neighbours of a point on the floor
//   4. write it as a binary_compressed PCD and read it back
//   5. compose SE(2) poses with the ⊕/⊖ operators of Liu et al. 2022, eq. 13
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>

#include <plumb/plumb.hpp>

int main() {
  using namespace plumb;

  // 1. Rays from the room centre to the walls, floor and ceiling.
  Rng rng(2026);
  PointCloud scan;
  const Vector3d half(3.0, 2.0, 1.4);
  for (int i = 0; i < 60000; ++i) {
    const Vector3d dir = Vector3d(rng.normal(), rng.normal(), rng.normal()).normalized();
    double t = std::numeric_limits<double>::infinity();
    for (int a = 0; a < 3; ++a) {
      if (dir[a] != 0.0) t = std::min(t, half[a] / std::abs(dir[a]));
    }
    const double range = t + rng.normal(0.0, 0.003);
    scan.points.push_back((range * dir).cast<float>());
  }
  for (int i = 0; i < 100; ++i) scan.points[i * 500].x() = std::numeric_limits<float>::quiet_NaN();
  std::printf("scan: %zu points (100 of them NaN)\n", scan.size());

  // 2. Voxel grid.
  VoxelGridSettings voxel_settings;
  voxel_settings.leaf_size = 0.05;
  const VoxelGridResult down = voxel_grid(scan, voxel_settings);
  std::printf("voxel grid 5 cm: %zu points, %zu NaN dropped, status %s\n", down.cloud.size(),
              down.num_dropped_non_finite, to_string(down.status));

  // 3. Nearest neighbours of a floor point.
  const KdTree3f tree(down.cloud);
  const Vector3f query(0.5f, 0.5f, -1.4f);
  const std::vector<Neighbor> nn = tree.knn(query, 5);
  std::printf("5 nearest to (0.5, 0.5, -1.4):");
  for (const Neighbor& n : nn) std::printf(" %.3f m", std::sqrt(n.dist_sq));
  std::printf("\n");

  // 4. PCD round trip.
  const std::string path = "/tmp/plumb_example_01.pcd";
  io::PcdWriteSettings pcd_settings;
  pcd_settings.encoding = io::PcdEncoding::kBinaryCompressed;
  io::write_pcd(path, down.cloud, pcd_settings);
  const PointCloud back = io::read_pcd(path);
  std::printf("wrote and read %s: %zu points\n", path.c_str(), back.size());

  // 5. SE(2): robot motion between two poses, r = ⊖q_k ⊕ q_k+1.
  const Pose2 q0{1.0, 2.0, 0.3}, q1{1.8, 2.4, 0.5};
  const Pose2 r = q0.ominus().oplus(q1);
  std::printf("motion q0 -> q1 in q0's frame: x %.4f m, y %.4f m, theta %.4f rad\n", r.x, r.y, r.theta);
  return back.size() == down.cloud.size() ? 0 : 1;
}
