// SPDX-License-Identifier: BSD-3-Clause
// `plumb scan2d LOG -o TRAJ.tum [--json]`: scan-matching odometry (PLICP with the raw wheel-odometry
// prior) over the FLASER scans of a CARMEN log; one TUM pose per FLASER scan, in log order.

#include <cstdio>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "registry.hpp"
#include "plumb/core/error.hpp"
#include "plumb/core/trajectory.hpp"
#include "plumb/io/carmen.hpp"
#include "plumb/io/trajectory.hpp"
#include "plumb/scan2d/scan_odometry.hpp"

namespace plumb::cli {
namespace {

struct Scan2dOptions {
  std::string log_path;
  std::string output_path;
  bool json = false;
  std::size_t local_map_size = 1;
  std::vector<double> laser_pose;  // x y theta of the laser on the robot
};

void run_scan2d(const Scan2dOptions& o) {
  const io::CarmenLog log = io::read_carmen(o.log_path);
  std::vector<LaserScan> scans;
  std::vector<Pose2> odometry;
  const std::vector<Pose2> prior = io::raw_odometry_at_lasers(log);
  for (std::size_t k = 0; k < log.lasers.size(); ++k) {
    if (log.lasers[k].kind != io::CarmenLaserKind::kFlaser) continue;
    scans.push_back(log.lasers[k].scan);
    odometry.push_back(prior[k]);
  }
  PLUMB_CHECK(!scans.empty(), o.log_path << ": no FLASER message");
  ScanOdometrySettings settings;
  settings.local_map_size = o.local_map_size;
  if (o.laser_pose.size() == 3) settings.T_base_laser = Pose2{o.laser_pose[0], o.laser_pose[1], o.laser_pose[2]};
  const ScanOdometryResult r = run_scan_odometry(scans, odometry, settings);

  Trajectory traj;
  for (std::size_t k = 0; k < scans.size(); ++k) traj.push_back(scans[k].stamp, r.poses[k].to_isometry());
  io::write_tum(traj, o.output_path);

  if (o.json) {
    nlohmann::json j = {{"scans", scans.size()},
                        {"matched", r.num_matched},
                        {"degenerate", r.num_degenerate},
                        {"fallbacks", r.num_fallbacks},
                        {"failures", r.num_fallbacks},
                        {"mean_iterations", r.mean_iterations},
                        {"ms_per_match", r.mean_match_ms},
                        {"output", o.output_path}};
    std::cout << j.dump(2) << '\n';
  } else {
    std::printf("%zu scans: %zu matched (%zu degenerate), %zu fallbacks to odometry; "
                "%.1f iterations, %.3f ms per match -> %s\n",
                scans.size(), r.num_matched, r.num_degenerate, r.num_fallbacks, r.mean_iterations,
                r.mean_match_ms, o.output_path.c_str());
  }
}

}  // namespace

void register_scan2d_command(CLI::App& app) {
  auto opts = std::make_shared<Scan2dOptions>();
  CLI::App* cmd = app.add_subcommand(
      "scan2d", "Scan-matching odometry (PLICP + wheel-odometry prior) over a CARMEN log's FLASER scans");
  cmd->add_option("log", opts->log_path, "CARMEN log (plain or .gz)")->required()->check(CLI::ExistingFile);
  cmd->add_option("-o,--output", opts->output_path, "Output TUM trajectory (one pose per FLASER scan)")
      ->required();
  cmd->add_flag("--json", opts->json, "Print a JSON summary");
  cmd->add_option("--local-map", opts->local_map_size, "Keyframes in the local map (default 1)")
      ->check(CLI::Range(1, 100));
  cmd->add_option("--laser-pose", opts->laser_pose, "Laser mounting pose on the robot: x y theta")
      ->expected(3);
  cmd->callback([opts] { run_scan2d(*opts); });
}

}  // namespace plumb::cli

PLUMB_CLI_COMMAND(scan2d, plumb::cli::register_scan2d_command);
