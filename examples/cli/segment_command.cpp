// SPDX-License-Identifier: BSD-3-Clause
// `plumb segment CLOUD [--sensor-height H] [--labels-out FILE] [--scan-out FILE.csv] [--json]`:
// ground, vertical-plane key points and decoration of one frame (segment_frame), optionally the
// per-point labels (one integer per input point: 0 decoration, 1 ground, 2 vertical) and the planar
// scan of the frame (cloud_to_scan, sensor frame, default band and bins) as CSV.

#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <limits>
#include <memory>
#include <string>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "cli_support.hpp"
#include "registry.hpp"
#include "plumb/core/error.hpp"
#include "plumb/io/cloud_io.hpp"
#include "plumb/scan2d/cloud_to_scan.hpp"
#include "plumb/segmentation/segment_frame.hpp"

namespace plumb::cli {
namespace {

struct SegmentOptions {
  std::string cloud_path;
  double sensor_height = std::numeric_limits<double>::quiet_NaN();
  std::string labels_out;
  std::string scan_out;
  bool json = false;
};

void write_labels(const std::string& path, const std::vector<std::int32_t>& labels) {
  std::ofstream out(path);
  PLUMB_CHECK(out.good(), path << ": cannot open for writing");
  for (std::int32_t l : labels) out << l << '\n';
  PLUMB_CHECK(out.good(), path << ": write failed");
}

void write_scan_csv(const std::string& path, const CloudToScanResult& r) {
  std::ofstream out(path);
  PLUMB_CHECK(out.good(), path << ": cannot open for writing");
  out << "beam,angle,range,x,y\n";
  out.precision(9);
  std::size_t next = 0;  // r.points / beam_indices are in beam order
  for (std::size_t b = 0; b < r.scan.size(); ++b) {
    out << b << ',' << r.scan.angle(b) << ',';
    if (next < r.beam_indices.size() && r.beam_indices[next] == b) {
      out << r.scan.ranges[b] << ',' << r.points[next].x() << ',' << r.points[next].y() << '\n';
      ++next;
    } else {
      out << "inf,nan,nan\n";
    }
  }
  PLUMB_CHECK(out.good(), path << ": write failed");
}

void run_segment(const SegmentOptions& o) {
  const PointCloud cloud = io::read_cloud(o.cloud_path);
  const auto t0 = std::chrono::steady_clock::now();
  SegmentSettings s;
  s.ground.sensor_height = o.sensor_height;
  const SegmentResult r = segment_frame(cloud, s);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (!o.labels_out.empty()) write_labels(o.labels_out, r.labels);
  if (!o.scan_out.empty()) write_scan_csv(o.scan_out, cloud_to_scan(cloud));

  const bool has_ground = r.ground.status == Status::kOk;
  const Vector3d& n = r.ground.plane.normal;
  if (o.json) {
    nlohmann::json ground = {{"num_points", r.num_ground}};
    ground["normal"] = has_ground ? nlohmann::json::array({n.x(), n.y(), n.z()}) : nlohmann::json(nullptr);
    ground["offset"] = has_ground ? nlohmann::json(r.ground.plane.offset) : nlohmann::json(nullptr);
    const nlohmann::json j = {{"ground", ground},
                              {"vertical", {{"num_planes", r.vertical.planes.size()}, {"num_points", r.num_vertical}}},
                              {"decoration", {{"num_points", r.num_other}}},
                              {"status", to_string(r.status)},
                              {"seconds", seconds}};
    std::cout << j.dump(2) << '\n';
  } else {
    if (has_ground) {
      std::printf("%zu points: ground %zu (n = %.4f %.4f %.4f, D = %.4f m), vertical %zu on %zu planes, "
                  "decoration %zu; %.1f ms\n",
                  cloud.size(), r.num_ground, n.x(), n.y(), n.z(), r.ground.plane.offset, r.num_vertical,
                  r.vertical.planes.size(), r.num_other, seconds * 1e3);
    } else {
      std::printf("%zu points: no ground (%s), vertical %zu on %zu planes, decoration %zu; %.1f ms\n",
                  cloud.size(), to_string(r.status), r.num_vertical, r.vertical.planes.size(), r.num_other,
                  seconds * 1e3);
    }
  }
}

}  // namespace

void register_segment_command(CLI::App& app) {
  auto opts = std::make_shared<SegmentOptions>();
  CLI::App* cmd = app.add_subcommand(
      "segment", "Ground, vertical planes and decoration of one LiDAR frame (sensor frame, z up)");
  cmd->add_option("cloud", opts->cloud_path, "Frame to segment (.pcd, .ply, .bin)")->required()->check(CLI::ExistingFile);
  cmd->add_option("--sensor-height", opts->sensor_height,
                  "Height of the sensor above the ground [m] (default: unknown, lowest large horizontal plane)")
      ->check(positive_number(1000.0));
  cmd->add_option("--labels-out", opts->labels_out,
                  "Write one label per input point, in input order (0 decoration, 1 ground, 2 vertical)");
  cmd->add_option("--scan-out", opts->scan_out, "Write the frame's planar scan as CSV (beam,angle,range,x,y)");
  cmd->add_flag("--json", opts->json, "Print a JSON summary");
  cmd->callback([opts] { naming_inputs({opts->cloud_path}, [&] { run_segment(*opts); }); });
}

}  // namespace plumb::cli

PLUMB_CLI_COMMAND(segment, plumb::cli::register_segment_command);
