// SPDX-License-Identifier: BSD-3-Clause
// Links plumb::app: a frame dump of three frames written, and its ground truth read back one pose per
// frame, as the runners measure against it.
#include <cstdio>
#include <filesystem>
#include <string>

#include <plumb/app/run.hpp>
#include <plumb/io/frame_dump.hpp>

int main() {
  const std::string dir = (std::filesystem::temp_directory_path() / "plumb_app_consumer_dump").string();
  plumb::Trajectory truth;
  {
    plumb::io::FrameDumpWriteSettings settings;
    settings.overwrite = true;
    plumb::io::FrameDumpWriter writer(dir, plumb::io::FrameDumpMeta{}, settings);
    plumb::PointCloud frame;
    frame.points.emplace_back(1.0f, 0.0f, 0.0f);
    for (int i = 0; i < 3; ++i) {
      Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
      pose.translation().x() = 0.5 * i;
      truth.push_back(0.1 * i, pose);
      writer.add_frame(0.1 * i, frame);
    }
    writer.write_ground_truth(truth);
    writer.close();
  }
  const plumb::io::FrameDumpReader dump(dir);
  const plumb::FrameGroundTruth gt = plumb::read_frame_ground_truth(dump, dump.num_frames());
  std::filesystem::remove_all(dir);
  const bool ok = gt.used && gt.note == "used" && gt.poses.size() == 3 && gt.poses.poses[2].translation().x() == 1.0;
  std::printf("plumb::app: frame dump ground truth %s\n", ok ? "ok" : "FAILED");
  return ok ? 0 : 1;
}
