// SPDX-License-Identifier: BSD-3-Clause
// Example 02: BIM-corrected odometry fed one frame at a time, as a robot's own loop would.
//   1. the building: IFC -> mesh -> BIM cloud (the model's surfaces with normals, every 5 cm)
//   2. where am I? the first LiDAR frame localized in the building, no hint (BimLocalizer)
//   3. per frame: undo the motion distortion with the wheel odometry, then BimOdometry::process()
//      with the frame and the wheel-odometry pose at its stamp; the pose comes back in the BIM frame
// Frames come from a frame dump here (`plumb simulate MODEL -o DIR`, or a robot's own recording, see
// the README); on a robot they come from the driver.
//
// usage: plumb_example_02_bim_odometry MODEL.ifc DUMP_DIR
#include <cmath>
#include <cstdio>
#include <exception>
#include <memory>

// What a robot's loop needs: the model (bim), deskewing (core) and the odometry (pipeline); io only
// because the frames come from a dump here.
#include <plumb/bim/bim_cloud.hpp>
#include <plumb/bim/ifc.hpp>
#include <plumb/bim/mesh.hpp>
#include <plumb/core/deskew.hpp>
#include <plumb/core/status.hpp>
#include <plumb/io/frame_dump.hpp>
#include <plumb/pipeline/bim_localizer.hpp>
#include <plumb/pipeline/bim_odometry.hpp>
#include <plumb/pipeline/pose_composer.hpp>

namespace {

double yaw_deg(const Eigen::Isometry3d& T) { return std::atan2(T.linear()(1, 0), T.linear()(0, 0)) * 180.0 / M_PI; }

}  // namespace

int main(int argc, char** argv) {
  using namespace plumb;
  if (argc != 3) {
    std::fprintf(stderr, "usage: %s MODEL.ifc DUMP_DIR\n", argv[0]);
    return 2;
  }
  try {
    // 1. The building.
    const bim::BimMesh mesh = bim::build_mesh(bim::read_ifc(argv[1]), bim::mesh_settings_with_spaces());
    const auto bim_cloud = std::make_shared<const PointCloud>(bim::sample_bim_cloud(mesh, 0.05));
    const io::FrameDumpReader dump(argv[2]);
    const Eigen::Isometry3d T_base_lidar = dump.meta().T_base_lidar;
    const OdometryInterpolator odom(dump.odometry());  // wheel odometry at any time
    auto read_frame = [&](std::size_t i) {
      PointCloud frame = dump.frame(i);
      deskew_frame(frame, dump.stamp(i), T_base_lidar,
                   [&](double t) { return odom.at(t).to_isometry(); });
      return frame;
    };

    // 2. The first frame in the building.
    const BimLocalizer localizer(mesh, *bim_cloud);
    const BimLocalization start = localizer.localize(read_frame(0), T_base_lidar);
    if (start.status != Status::kOk) {
      std::fprintf(stderr, "not localized: %s%s (give a start hint: localize(frame, T_base_lidar, hint))\n",
                   to_string(start.status), start.ambiguous ? ", two places fit" : "");
      return 1;
    }
    std::printf("start: x %.3f m, y %.3f m, yaw %.2f deg (storey %d, score %.2f)\n", start.T_world_base.translation().x(),
                start.T_world_base.translation().y(), yaw_deg(start.T_world_base), start.storey, start.score);

    // 3. The loop.
    BimOdometrySettings settings;
    settings.T_base_lidar = T_base_lidar;
    BimOdometry odometry(bim_cloud, start.T_world_base, settings);
    for (std::size_t i = 0; i < dump.num_frames(); ++i) {
      const BimFrameResult r = odometry.process(read_frame(i), dump.stamp(i), odom.at(dump.stamp(i)));
      if (i % 50 == 0 || i + 1 == dump.num_frames()) {
        std::printf("%s %zu: t %.2f s, x %.3f m, y %.3f m, yaw %.2f deg, BIM anchor %s\n",
                    i + 1 == dump.num_frames() ? "last frame" : "frame", i, r.stamp, r.T_world_base.translation().x(),
                    r.T_world_base.translation().y(), yaw_deg(r.T_world_base), to_string(r.anchor.decision));
      }
    }
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
}
