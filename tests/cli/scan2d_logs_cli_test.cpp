// SPDX-License-Identifier: BSD-3-Clause
// `plumb scan2d` on degraded variants of the shared intel log, made in the test: the same log with
// its stamps quantised to 10 s (a logger writing coarse stamps) must give the same odometry as the
// original, every scan kept. Reference: the log's SLAM-corrected poses.

#include <zlib.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "cli_runner.hpp"
#include "plumb/core/pose2.hpp"
#include "plumb/core/trajectory.hpp"
#include "plumb/io/carmen.hpp"
#include "plumb/io/trajectory.hpp"
#include "test_data.hpp"

namespace {

using plumb::Pose2;
using plumb::test::CliTest;
using plumb::test::run_cli;

std::string gunzip_text(const std::string& path) {
  gzFile f = gzopen(path.c_str(), "rb");
  EXPECT_NE(f, nullptr) << path;
  std::string text;
  char buf[1 << 16];
  for (int n; f != nullptr && (n = gzread(f, buf, sizeof(buf))) > 0;) {
    text.append(buf, static_cast<std::size_t>(n));
  }
  if (f != nullptr) gzclose(f);
  return text;
}

/// The log with the ipc and logger stamps of its FLASER and ODOM lines floored to `quantum` seconds.
std::string quantised(const std::string& text, double quantum) {
  std::istringstream in(text);
  std::ostringstream out;
  out.precision(12);
  for (std::string line; std::getline(in, line);) {
    std::istringstream ls(line);
    std::vector<std::string> f;
    for (std::string w; ls >> w;) f.push_back(w);
    if (f.size() >= 4 && (f[0] == "FLASER" || f[0] == "ODOM")) {
      for (std::size_t k : {f.size() - 3, f.size() - 1}) {
        f[k] = std::to_string(std::floor(std::stod(f[k]) / quantum) * quantum);
      }
      for (std::size_t k = 0; k < f.size(); ++k) out << (k > 0 ? " " : "") << f[k];
      out << '\n';
    } else {
      out << line << '\n';
    }
  }
  return out.str();
}

/// Mean relation error over pairs `span` apart: est poses against the reference poses [cm, deg].
std::pair<double, double> relation_error(const plumb::Trajectory& est, const std::vector<Pose2>& ref,
                                         std::size_t span) {
  double st = 0.0, sr = 0.0;
  std::size_t n = 0;
  for (std::size_t i = 0; i + span < ref.size() && i + span < est.size(); ++i) {
    auto pose2 = [](const Eigen::Isometry3d& T) {
      return Pose2{T.translation().x(), T.translation().y(), std::atan2(T.linear()(1, 0), T.linear()(0, 0))};
    };
    const Pose2 a = ref[i].ominus().oplus(ref[i + span]);
    const Pose2 b = pose2(est.poses[i]).ominus().oplus(pose2(est.poses[i + span]));
    const Pose2 e = a.ominus().oplus(b);
    st += std::hypot(e.x, e.y);
    sr += std::abs(plumb::wrap_angle(e.theta));
    ++n;
  }
  return {100.0 * st / static_cast<double>(n), 180.0 / M_PI * sr / static_cast<double>(n)};
}

TEST_F(CliTest, Scan2dOnAQuantisedClockKeepsEveryScanAndItsAccuracy) {
  PLUMB_REQUIRE_DATA(path, "laser2d/carmen_corrected/intel-corrected.log.gz");
  const plumb::io::CarmenLog log = plumb::io::read_carmen(path);
  std::vector<Pose2> all, increasing;  // corrected poses of every FLASER / of those whose stamp increases
  double last = -1e300;
  for (const auto& l : log.lasers) {
    if (l.kind != plumb::io::CarmenLaserKind::kFlaser) continue;
    all.push_back(l.pose);
    if (l.scan.stamp > last) increasing.push_back(l.pose);
    last = std::max(last, l.scan.stamp);
  }
  const std::string q_log = plumb::test::temp_path("scan2d_intel_q10.log");
  std::ofstream(q_log) << quantised(gunzip_text(path), 10.0);
  const std::string orig_tum = plumb::test::temp_path("scan2d_intel.tum");
  const std::string q_tum = plumb::test::temp_path("scan2d_intel_q10.tum");
  plumb::test::RunResult r = run_cli("scan2d '" + path + "' -o '" + orig_tum + "' --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = run_cli("scan2d '" + q_log + "' -o '" + q_tum + "' --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j.at("scans"), all.size());  // none dropped to the coarse clock
  EXPECT_EQ(j.at("dropped_scans"), 0);
  EXPECT_GT(j.at("respread_stamps").get<std::size_t>(), all.size() / 2);
  EXPECT_NE(r.err.find("share their stamp"), std::string::npos) << r.err;

  const plumb::Trajectory orig = plumb::io::read_tum(orig_tum), q = plumb::io::read_tum(q_tum);  // stamps increase
  ASSERT_EQ(orig.size(), increasing.size());
  ASSERT_EQ(q.size(), all.size());
  for (std::size_t span : {std::size_t{1}, std::size_t{10}}) {
    const auto [ot, orot] = relation_error(orig, increasing, span);
    const auto [qt, qrot] = relation_error(q, all, span);
    EXPECT_LT(qt, 1.2 * ot) << "span " << span;
    EXPECT_LT(qrot, 1.2 * orot) << "span " << span;
  }
  std::remove(q_log.c_str());
  std::remove(orig_tum.c_str());
  std::remove(q_tum.c_str());
}

}  // namespace
