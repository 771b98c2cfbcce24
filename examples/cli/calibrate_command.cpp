// SPDX-License-Identifier: BSD-3-Clause
// `plumb calibrate TUPLES` or `plumb calibrate --log LOG --wheels WHEELS.csv`: wheel radii, axle and
// laser pose of a differential-drive robot (Censi, Franchi, Marchionni, Oriolo, T-RO 2013), from a
// tuple file in Censi's format or straight from a robot's laser log and wheel encoder log (tuples
// made by PLICP scan matching).

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
#include "plumb/calibration/odometry_laser.hpp"
#include "plumb/core/error.hpp"
#include "plumb/calibration/tuple_extraction.hpp"
#include "plumb/io/calib_tuples.hpp"
#include "plumb/io/carmen.hpp"
#include "plumb/io/input_file.hpp"
#include "plumb/io/wheel_encoders.hpp"

namespace plumb::cli {
namespace {

struct CalibrateOptions {
  std::string tuples_path;
  std::string log_path;
  std::string wheels_path;
  std::string tuples_out;
  double ticks_per_revolution = 0.0;
  std::size_t spacing = 5;
  std::vector<double> nominal;  // r_L r_R axle l_x l_y l_theta
  bool json = false;
  int outlier_iterations = OdometryLaserCalibrationSettings{}.outlier_iterations;
  double outlier_quantile = OdometryLaserCalibrationSettings{}.outlier_quantile;
};

/// What tuple extraction from a log did (absent when tuples came from a file).
struct ExtractionSummary {
  std::size_t scans = 0, pairs = 0, tuples = 0, without_odometry = 0, speed_changes = 0, match_failures = 0,
              dropped_scans = 0;
};

/// Tuples from a laser log + wheel encoder log: PLICP between scans `spacing` apart.
std::vector<CalibrationTuple> tuples_from_logs(const CalibrateOptions& o, ExtractionSummary& summary) {
  const io::CarmenLog log = io::read_carmen(o.log_path);
  PLUMB_CHECK(!log.lasers.empty(), o.log_path << ": no laser scan (FLASER, RAWLASER or ROBOTLASER1)");
  // As `plumb scan2d`: a scan whose stamp goes back is dropped with a warning naming its line, and
  // scans sharing a stamp are spread, rather than refusing the whole log; wheel readings are
  // interpolated at the resulting stamps.
  const io::StampOrder order = records_in_time_order(
      o.log_path, log.lasers.size(), [&](std::size_t k) { return log.lasers[k].scan.stamp; },
      [&](std::size_t k) { return log.lasers[k].line; }, "scan");
  std::vector<LaserScan> scans;
  scans.reserve(order.kept.size());
  for (std::size_t j = 0; j < order.kept.size(); ++j) {
    scans.push_back(log.lasers[order.kept[j]].scan);
    scans.back().stamp = order.stamps[j];
  }
  summary.dropped_scans = order.dropped.size();
  io::WheelEncoderReadSettings wheel_settings;
  wheel_settings.ticks_per_revolution = o.ticks_per_revolution;
  const std::vector<WheelEncoderReading> wheels = io::read_wheel_encoders(o.wheels_path, wheel_settings);

  TupleExtractionSettings settings;
  settings.scan_spacing = o.spacing;
  if (o.nominal.size() == 6) {
    settings.nominal = {o.nominal[0], o.nominal[1], o.nominal[2], Pose2{o.nominal[3], o.nominal[4], o.nominal[5]}};
  }
  const TupleExtractionResult ex = extract_calibration_tuples(scans, wheels, plicp_scan_matcher(), settings);
  summary.scans = scans.size();
  summary.pairs = ex.num_pairs;
  summary.tuples = ex.tuples.size();
  summary.without_odometry = ex.num_without_odometry;
  summary.speed_changes = ex.num_speed_changes;
  summary.match_failures = ex.num_match_failures;
  PLUMB_CHECK(ex.status == Status::kOk,
              o.log_path << " + " << o.wheels_path << ": no calibration tuple: " << ex.num_pairs << " scan pairs, "
                         << ex.num_without_odometry << " without wheel readings around their stamps (do the two "
                         << "logs share a clock?), " << ex.num_speed_changes << " with changing wheel speeds, "
                         << ex.num_match_failures << " refused by the scan matcher");
  if (!o.tuples_out.empty()) io::write_calib_tuples(ex.tuples, o.tuples_out);
  return ex.tuples;
}

void run_calibrate(const CalibrateOptions& o) {
  const bool from_file = !o.tuples_path.empty();
  const bool from_logs = !o.log_path.empty() || !o.wheels_path.empty();
  PLUMB_CHECK(from_file != from_logs, "calibrate: give either a TUPLES file or --log LOG --wheels WHEELS.csv");
  PLUMB_CHECK(from_file || (!o.log_path.empty() && !o.wheels_path.empty()),
              "calibrate: --log and --wheels go together (laser log and wheel encoder log)");
  PLUMB_CHECK(o.nominal.empty() || o.nominal.size() == 6,
              "calibrate: --nominal takes 6 values (r_L r_R axle l_x l_y l_theta), got " << o.nominal.size());
  if (o.nominal.size() == 6) {
    PLUMB_CHECK(o.nominal[0] > 0.0 && o.nominal[1] > 0.0 && o.nominal[2] > 0.0,
                "--nominal: the wheel radii and the axle must be > 0 m, got " << o.nominal[0] << ' ' << o.nominal[1]
                                                                                << ' ' << o.nominal[2]);
    PLUMB_CHECK(std::abs(o.nominal[5]) <= 2.0 * 3.14159265358979323846,
                "--nominal: l_theta " << o.nominal[5] << " is outside [-2 pi, 2 pi] (radians, not degrees)");
  }
  // Name a directory or a missing file as such (the readers would report it as malformed).
  for (const std::string* path : {&o.tuples_path, &o.log_path, &o.wheels_path}) {
    if (!path->empty()) io::check_input_file(*path);
  }
  ExtractionSummary summary;
  const std::vector<CalibrationTuple> tuples =
      from_file ? io::read_calib_tuples(o.tuples_path) : tuples_from_logs(o, summary);
  const std::string source = from_file ? o.tuples_path : o.log_path;
  OdometryLaserCalibrationSettings settings;
  settings.outlier_iterations = o.outlier_iterations;
  settings.outlier_quantile = o.outlier_quantile;
  const OdometryLaserCalibrationResult r = calibrate_odometry_laser(tuples, settings);
  if (r.status != Status::kOk) {
    PLUMB_THROW(source << ": calibration failed (" << to_string(r.status) << ") with "
                              << r.num_tuples << " tuples"
                              << (r.status == Status::kDegenerate
                                      ? ": the motion must mix turning and driving (straight runs, "
                                        "turns on the spot or arcs)"
                                      : ""));
  }
  const OdometryLaserParams& p = r.params;
  if (o.json) {
    nlohmann::json cov = nlohmann::json::array();
    for (int i = 0; i < 6; ++i) {
      nlohmann::json row = nlohmann::json::array();
      for (int j = 0; j < 6; ++j) row.push_back(r.covariance(i, j));
      cov.push_back(row);
    }
    nlohmann::json out = {
        {"axle", p.axle},
        {"l_diam", 2.0 * p.radius_left},
        {"r_diam", 2.0 * p.radius_right},
        {"l_x", p.laser.x},
        {"l_y", p.laser.y},
        {"l_theta", p.laser.theta},
        {"covariance", cov},
        {"status", to_string(r.status)},
        {"num_tuples", r.num_tuples},
        {"num_inliers", r.num_inliers},
        {"laser_noise_std", {r.laser_noise_std(0), r.laser_noise_std(1), r.laser_noise_std(2)}},
    };
    if (from_logs) {
      out["extraction"] = {{"scans", summary.scans},
                           {"pairs", summary.pairs},
                           {"tuples", summary.tuples},
                           {"without_odometry", summary.without_odometry},
                           {"speed_changes", summary.speed_changes},
                           {"match_failures", summary.match_failures},
                           {"dropped_scans", summary.dropped_scans}};
    }
    std::cout << out.dump() << '\n';
    return;
  }
  auto sd = [&r](int i) { return std::sqrt(r.covariance(i, i)); };
  if (from_logs) {
    std::printf("%zu scans (%zu dropped, stamp going back), %zu pairs: %zu tuples; skipped %zu without wheel "
                "readings, %zu with changing wheel speeds, %zu refused by the scan matcher\n",
                summary.scans, summary.dropped_scans, summary.pairs, summary.tuples, summary.without_odometry,
                summary.speed_changes, summary.match_failures);
  }
  std::printf("calibration of %s: %zu tuples, %zu used after outlier rejection\n", source.c_str(),
              r.num_tuples, r.num_inliers);
  std::printf("  %-22s %14s %12s\n", "parameter", "estimate", "std dev");
  std::printf("  %-22s %14.7f %12.7f\n", "left wheel diam [m]", 2.0 * p.radius_left, 2.0 * sd(0));
  std::printf("  %-22s %14.7f %12.7f\n", "right wheel diam [m]", 2.0 * p.radius_right, 2.0 * sd(1));
  std::printf("  %-22s %14.7f %12.7f\n", "axle [m]", p.axle, sd(2));
  std::printf("  %-22s %14.7f %12.7f\n", "laser x [m]", p.laser.x, sd(3));
  std::printf("  %-22s %14.7f %12.7f\n", "laser y [m]", p.laser.y, sd(4));
  std::printf("  %-22s %14.7f %12.7f\n", "laser theta [rad]", p.laser.theta, sd(5));
  std::printf("  %-22s %14.4f %12s\n", "laser theta [deg]", p.laser.theta * 180.0 / 3.14159265358979323846, "");
  std::printf("scan-matcher noise (std): x %.3g mm, y %.3g mm, theta %.3g deg\n",
              r.laser_noise_std(0) * 1e3, r.laser_noise_std(1) * 1e3,
              r.laser_noise_std(2) * 180.0 / 3.14159265358979323846);
}

}  // namespace

void register_calibrate_command(CLI::App& app) {
  auto options = std::make_shared<CalibrateOptions>();
  CLI::App* cmd = app.add_subcommand(
      "calibrate", "Wheel radii, axle and laser pose from calibration tuples (Censi et al. T-RO 2013)");
  cmd->add_option("TUPLES", options->tuples_path,
                  "Tuple file: JSON lines {\"T\", \"phi_l\", \"phi_r\", \"sm\": [x, y, theta]}");
  cmd->footer(
      "With --log, a scan whose stamp goes back in time is dropped, with a warning on stderr naming\n"
      "LOG:LINE, and counted in extraction.dropped_scans of --json; scans sharing a stamp are kept,\n"
      "their stamps spread evenly to the next one.");
  cmd->add_option("--log", options->log_path,
                  "Instead of TUPLES: CARMEN laser log (FLASER / RAWLASER / ROBOTLASER1, plain or .gz); "
                  "tuples are made by PLICP between scans --spacing apart");
  cmd->add_option("--wheels", options->wheels_path,
                  "With --log: wheel encoder CSV 'stamp,left,right' (cumulative wheel angles [rad], or ticks "
                  "with --ticks-per-rev), on the laser log's clock");
  cmd->add_option("--ticks-per-rev", options->ticks_per_revolution,
                  "Wheel columns are encoder ticks, this many per wheel revolution")
      ->check(positive_number(1e9));
  cmd->add_option("--spacing", options->spacing, "With --log: match scan k against scan k + spacing")
      ->check(finite_number(1, 1000))
      ->capture_default_str();
  cmd->add_option("--nominal", options->nominal,
                  "With --log: nominal r_L r_R axle [m] l_x l_y [m] l_theta [rad], only to seed the scan matcher")
      ->expected(6)
      ->check(finite_number(-100.0, 100.0));
  cmd->add_option("--tuples-out", options->tuples_out, "With --log: also write the tuples (Censi's format)");
  cmd->add_flag("--json", options->json,
                "Print one JSON object: axle, l_diam, r_diam [m], l_x, l_y [m], l_theta [rad], covariance "
                "6x6 of (r_L, r_R, axle, l_x, l_y, l_theta) (radii, as Censi's tool)");
  cmd->add_option("--outlier-iterations", options->outlier_iterations, "Rounds of outlier rejection")
      ->check(finite_number(0.0, 1000.0))
      ->capture_default_str();
  cmd->add_option("--outlier-quantile", options->outlier_quantile,
                  "Per round, drop tuples with residuals above this quantile")
      ->check(finite_number(0.5, 1.0))
      ->capture_default_str();
  cmd->callback([options]() {
    naming_inputs({options->tuples_path, options->log_path, options->wheels_path}, [&] { run_calibrate(*options); });
  });
}

}  // namespace plumb::cli

PLUMB_CLI_COMMAND(calibrate, plumb::cli::register_calibrate_command);
