// SPDX-License-Identifier: BSD-3-Clause
// `plumb calibrate TUPLES`: wheel radii, axle and laser pose of a differential-drive robot from a
// tuple file in Censi's format (Censi, Franchi, Marchionni, Oriolo, T-RO 2013).

#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>
#include <string>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "registry.hpp"
#include "plumb/calibration/odometry_laser.hpp"
#include "plumb/core/error.hpp"
#include "plumb/io/calib_tuples.hpp"

namespace plumb::cli {
namespace {

struct CalibrateOptions {
  std::string tuples_path;
  bool json = false;
  int outlier_iterations = OdometryLaserCalibrationSettings{}.outlier_iterations;
  double outlier_quantile = OdometryLaserCalibrationSettings{}.outlier_quantile;
};

void run_calibrate(const CalibrateOptions& o) {
  const std::vector<CalibrationTuple> tuples = io::read_calib_tuples(o.tuples_path);
  OdometryLaserCalibrationSettings settings;
  settings.outlier_iterations = o.outlier_iterations;
  settings.outlier_quantile = o.outlier_quantile;
  const OdometryLaserCalibrationResult r = calibrate_odometry_laser(tuples, settings);
  if (r.status != Status::kOk) {
    PLUMB_THROW(o.tuples_path << ": calibration failed (" << to_string(r.status) << ") with "
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
    const nlohmann::json out = {
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
    std::cout << out.dump() << '\n';
    return;
  }
  auto sd = [&r](int i) { return std::sqrt(r.covariance(i, i)); };
  std::printf("calibration of %s: %zu tuples, %zu used after outlier rejection\n", o.tuples_path.c_str(),
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
                  "Tuple file: JSON lines {\"T\", \"phi_l\", \"phi_r\", \"sm\": [x, y, theta]}")
      ->required();
  cmd->add_flag("--json", options->json,
                "Print one JSON object: axle, l_diam, r_diam [m], l_x, l_y [m], l_theta [rad], covariance "
                "6x6 of (r_L, r_R, axle, l_x, l_y, l_theta) (radii, as Censi's tool)");
  cmd->add_option("--outlier-iterations", options->outlier_iterations, "Rounds of outlier rejection")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd->add_option("--outlier-quantile", options->outlier_quantile,
                  "Per round, drop tuples with residuals above this quantile")
      ->check(CLI::Range(0.5, 1.0))
      ->capture_default_str();
  cmd->callback([options]() { run_calibrate(*options); });
}

}  // namespace plumb::cli

PLUMB_CLI_COMMAND(calibrate, plumb::cli::register_calibrate_command);
