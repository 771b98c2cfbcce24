// SPDX-License-Identifier: BSD-3-Clause
// `plumb calibrate --log LOG --wheels WHEELS.csv`: the one-command calibration from a robot's own
// data. A simulated differential-drive robot with known wheel radii, axle and laser pose drives in
// a polygonal room; its laser log (CARMEN FLASER, noisy ranges) and encoder log (CSV, ticks) are
// written as a user would have them, and the command must recover the simulated parameters.

#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "cli_runner.hpp"
#include "plumb/core/pose2.hpp"
#include "plumb/core/rng.hpp"
#include "plumb/io/calib_tuples.hpp"
#include "scan2d/scan_sim.hpp"
#include "test_data.hpp"

namespace {

using plumb::Pose2;
using plumb::test::RunResult;

struct Params {
  double r_l, r_r, axle;
  Pose2 laser;
};
const Params kTruth{0.0503, 0.0497, 0.41, Pose2{0.15, -0.04, 0.06}};
constexpr double kTicksPerRev = 2048.0;
constexpr double kSegment = 2.0;  // wheel speeds are constant for 2 s, then reversed for 2 s

/// Writes a FLASER log (10 Hz) and a ticks CSV (50 Hz) of a robot whose wheel speeds are drawn per
/// segment and then played backwards, so it stays near its start in the room.
void write_logs(const std::string& log_path, const std::string& wheels_path, int pairs, std::uint64_t seed) {
  plumb::Rng rng(seed);
  std::vector<std::pair<double, double>> speeds;  // (phi_l, phi_r) per segment [rad/s]
  for (int s = 0; s < pairs; ++s) {
    double l = rng.uniform(-6.0, 6.0), r = rng.uniform(-6.0, 6.0);
    if (s % 3 == 0) r = -l;  // spin in place
    if (s % 3 == 1) r = l * rng.uniform(0.8, 1.0);  // nearly straight
    speeds.push_back({l, r});
    speeds.push_back({-l, -r});
  }
  const double duration = kSegment * static_cast<double>(speeds.size());
  // Exact state at t: integrate each segment's arc in closed form.
  auto state = [&](double t, double& al, double& ar) {
    Pose2 q;
    al = ar = 0.0;
    for (std::size_t s = 0; s < speeds.size(); ++s) {
      const double dt = std::min(std::max(t - kSegment * static_cast<double>(s), 0.0), kSegment);
      if (dt <= 0.0) break;
      al += speeds[s].first * dt;
      ar += speeds[s].second * dt;
      const double vl = kTruth.r_l * speeds[s].first, vr = kTruth.r_r * speeds[s].second;
      const double v = 0.5 * (vl + vr), w = (vr - vl) / kTruth.axle, th = w * dt;
      q = q.oplus(std::abs(w) < 1e-12 ? Pose2{v * dt, 0, 0}
                                      : Pose2{v / w * std::sin(th), v / w * (1 - std::cos(th)), th});
    }
    return q;
  };
  const Pose2 start{0.3, 0.2, 0.1};
  const auto world = plumb::test::room_world();
  std::ofstream log(log_path);
  log.precision(17);
  log << "# simulated robot for plumb calibrate\n";
  for (int k = 0; 0.1 * k <= duration; ++k) {
    const double t = 100.0 + 0.1 * k + 0.013;  // laser clock offset from the wheel samples
    double al = 0, ar = 0;
    const Pose2 base = start.oplus(state(t - 100.0, al, ar));
    const plumb::LaserScan scan = plumb::test::cast_scan(world, base.oplus(kTruth.laser), 181,
                                                         plumb::test::kPi, 30.0, 0.005, &rng);
    log << "FLASER " << scan.ranges.size();
    for (float r : scan.ranges) log << ' ' << r;
    log << " 0 0 0 0 0 0 " << t << " sim " << t << '\n';
  }
  std::ofstream wheels(wheels_path);
  wheels.precision(17);
  wheels << "stamp,left_ticks,right_ticks\n";
  for (int k = 0; 0.02 * k <= duration + 0.2; ++k) {
    const double t = 0.02 * k;
    double al = 0, ar = 0;
    state(t, al, ar);
    wheels << 100.0 + t << ',' << std::round(al / (2 * plumb::test::kPi) * kTicksPerRev) << ','
           << std::round(ar / (2 * plumb::test::kPi) * kTicksPerRev) << '\n';
  }
}

using CalibrateLogsCliTest = plumb::test::CliTest;

TEST_F(CalibrateLogsCliTest, RecoversSimulatedRobotFromLaserAndTickLogs) {
  const std::string log = plumb::test::temp_path("calib_sim.log");
  const std::string wheels = plumb::test::temp_path("calib_sim_wheels.csv");
  const std::string tuples = plumb::test::temp_path("calib_sim.tuple");
  write_logs(log, wheels, 24, 7);
  const RunResult r = plumb::test::run_cli("calibrate --log '" + log + "' --wheels '" + wheels +
                                           "' --ticks-per-rev 2048 --tuples-out '" + tuples + "' --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  auto num = [&](const char* key) { return plumb::test::json_number(r.out, "", key); };
  // 5 mm range noise, tick quantisation, 10 Hz scans: measured errors are ~0.03 % on the wheels and
  // axle, < 0.3 mm and 0.03 deg on the laser pose; the bounds leave a few times that.
  EXPECT_NEAR(num("l_diam"), 2 * kTruth.r_l, 2 * kTruth.r_l * 0.001);
  EXPECT_NEAR(num("r_diam"), 2 * kTruth.r_r, 2 * kTruth.r_r * 0.001);
  EXPECT_NEAR(num("axle"), kTruth.axle, kTruth.axle * 0.002);
  EXPECT_NEAR(num("l_x"), kTruth.laser.x, 0.002);
  EXPECT_NEAR(num("l_y"), kTruth.laser.y, 0.002);
  EXPECT_NEAR(num("l_theta"), kTruth.laser.theta, 0.1 * plumb::test::kPi / 180);
  // Pairs across the speed reversals are dropped, not fed to the solver.
  EXPECT_GT(plumb::test::json_number(r.out, "extraction", "speed_changes"), 100.0);
  // The tuples written alongside are the ones used: Censi's format, one per matched pair.
  const auto written = plumb::io::read_calib_tuples(tuples);
  EXPECT_EQ(static_cast<double>(written.size()), num("tuples"));
  EXPECT_GT(written.size(), 50u);
}

TEST_F(CalibrateLogsCliTest, LogsOnDifferentClocksGiveAClearError) {
  const std::string log = plumb::test::temp_path("calib_clock.log");
  const std::string wheels = plumb::test::temp_path("calib_clock_wheels.csv");
  write_logs(log, wheels, 2, 3);
  std::ofstream shifted(plumb::test::temp_path("calib_clock_wheels_shifted.csv"));
  shifted << "stamp,left,right\n0,0,0\n1,1,1\n2,2,2\n";
  shifted.close();
  const RunResult r = plumb::test::run_cli("calibrate --log '" + log + "' --wheels '" +
                                           plumb::test::temp_path("calib_clock_wheels_shifted.csv") + "'");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("share a clock"), std::string::npos) << r.err;
}

TEST_F(CalibrateLogsCliTest, MisuseIsReported) {
  RunResult r = plumb::test::run_cli("calibrate");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("either a TUPLES file or --log"), std::string::npos) << r.err;
  r = plumb::test::run_cli("calibrate --log x.log");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("go together"), std::string::npos) << r.err;
  r = plumb::test::run_cli("calibrate --log /nonexistent.log --wheels /nonexistent.csv");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("/nonexistent.log"), std::string::npos) << r.err;
}

}  // namespace
