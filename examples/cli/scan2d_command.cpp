// SPDX-License-Identifier: BSD-3-Clause
// `plumb scan2d LOG -o TRAJ.tum [--json]`: scan-matching odometry (PLICP with the raw wheel-odometry
// prior) over the FLASER scans of a CARMEN log; one TUM pose per FLASER scan, in log order.
// A scan whose stamp goes back in time is dropped with a warning naming the log's line; scans that
// share a stamp (a quantised clock) are kept in message order with their stamps spread (see
// records_in_time_order), so the TUM file always goes forward in time.
// Exit code 3 (kExitJobFailed) when every scan after the first fell back to wheel odometry: the
// file is written, but it holds no scan matching at all.

#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "cli_support.hpp"
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
  std::vector<std::size_t> flasers;  // indices into log.lasers
  for (std::size_t k = 0; k < log.lasers.size(); ++k) {
    if (log.lasers[k].kind == io::CarmenLaserKind::kFlaser) flasers.push_back(k);
  }
  PLUMB_CHECK(!flasers.empty(), o.log_path << ": no FLASER message");
  const io::StampOrder order = records_in_time_order(
      o.log_path, flasers.size(), [&](std::size_t i) { return log.lasers[flasers[i]].scan.stamp; },
      [&](std::size_t i) { return log.lasers[flasers[i]].line; }, "scan");
  for (std::size_t j = 0; j < order.kept.size(); ++j) {
    const std::size_t i = order.kept[j];
    scans.push_back(log.lasers[flasers[i]].scan);
    scans.back().stamp = order.stamps[j];
    odometry.push_back(prior[flasers[i]]);  // by message order where the stamps do not bracket the scan
  }
  const std::size_t dropped = order.dropped.size();
  ScanOdometrySettings settings;
  settings.local_map_size = o.local_map_size;
  if (o.laser_pose.size() == 3) {
    PLUMB_CHECK(std::abs(o.laser_pose[2]) <= 2.0 * kPi,
                "--laser-pose: theta " << o.laser_pose[2] << " rad is outside [-2 pi, 2 pi] (radians, not degrees)");
    settings.T_base_laser = Pose2{o.laser_pose[0], o.laser_pose[1], o.laser_pose[2]};
  }
  const ScanOdometryResult r = run_scan_odometry(scans, odometry, settings);

  Trajectory traj;
  for (std::size_t k = 0; k < scans.size(); ++k) traj.push_back(scans[k].stamp, r.poses[k].to_isometry());
  io::write_tum(traj, o.output_path);

  if (o.json) {
    nlohmann::json j = {{"scans", scans.size()},
                        {"matched", r.num_matched},
                        {"degenerate", r.num_degenerate},
                        {"prior_free", r.num_prior_free},
                        {"fallbacks", r.num_fallbacks},
                        {"failures", r.num_fallbacks},
                        {"dropped_scans", dropped},
                        {"respread_stamps", order.respread},
                        {"mean_iterations", r.mean_iterations},
                        {"ms_per_match", r.mean_match_ms},
                        {"output", o.output_path}};
    std::cout << j.dump(2) << '\n';
  } else {
    std::printf("%zu scans: %zu matched (%zu degenerate, %zu prior-free), %zu fallbacks to odometry, %zu dropped (stamp going "
                "back); %.1f iterations, %.3f ms per match -> %s\n",
                scans.size(), r.num_matched, r.num_degenerate, r.num_prior_free, r.num_fallbacks, dropped, r.mean_iterations,
                r.mean_match_ms, o.output_path.c_str());
  }
  if (scans.size() > 1 && r.num_matched == 0) {
    throw JobFailed(o.log_path + ": scan matching failed on every one of the " + std::to_string(scans.size() - 1) +
                    " scans after the first; " + o.output_path + " holds the wheel odometry only");
  }
}

}  // namespace

void register_scan2d_command(CLI::App& app) {
  auto opts = std::make_shared<Scan2dOptions>();
  CLI::App* cmd = app.add_subcommand(
      "scan2d", "Scan-matching odometry (PLICP + wheel-odometry prior) over a CARMEN log's FLASER scans");
  cmd->footer(
      "A FLASER scan whose stamp goes back in time is dropped, with a warning on stderr naming\n"
      "LOG:LINE, and counted as dropped_scans in --json; scans sharing a stamp (a quantised clock)\n"
      "are kept in log order, their stamps spread to the next one (respread_stamps in --json).\n"
      "Exit codes: 0 ok; 1 unusable input (message names it); 3 the trajectory was written but every\n"
      "scan after the first fell back to wheel odometry (no scan matched); >= 100 usage errors.");
  cmd->add_option("log", opts->log_path, "CARMEN log (plain or .gz)")->required()->check(CLI::ExistingFile);
  cmd->add_option("-o,--output", opts->output_path, "Output TUM trajectory (one pose per FLASER scan)")
      ->required();
  cmd->add_flag("--json", opts->json, "Print a JSON summary");
  cmd->add_option("--local-map", opts->local_map_size, "Keyframes in the local map (default 1)")
      ->check(finite_number(1, 100));
  cmd->add_option("--laser-pose", opts->laser_pose,
                  "Laser mounting pose on the robot: x y [m] (within 100 m) theta [rad] (within 2 pi)")
      ->expected(3)
      ->check(finite_number(-100.0, 100.0));
  cmd->callback([opts] { naming_inputs({opts->log_path}, [&] { run_scan2d(*opts); }); });
}

}  // namespace plumb::cli

PLUMB_CLI_COMMAND(scan2d, plumb::cli::register_scan2d_command);
