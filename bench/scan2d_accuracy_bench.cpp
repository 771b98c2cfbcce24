// SPDX-License-Identifier: BSD-3-Clause
// Accuracy of the 2D scan-matching odometry (ScanOdometry, defaults) on the shared CARMEN logs and
// on degraded variants of them (beams at 1 deg, wheel slip, an odometry prior held for 10 s): one
// run over the whole log per benchmark; the counters are the mean relation errors against the
// log's corrected poses over 1, 10 and 50 scans (cm, deg), the raw odometry's over the same spans
// (how each source's error grows with the span), and the
// scans matched from a prior-free start or fallen back to the odometry; `_fused` runs are the same
// with ScanOdometrySettings::fuse_prior on. CSM's figures on the same
// logs are in laser2d/csm/csm_reference.json (see docs/results.md).

#include <string>

#include <benchmark/benchmark.h>

#include "bench_data.hpp"
#include "plumb/core/error.hpp"
#include "plumb/scan2d/scan_odometry.hpp"
#include "scan2d/log_variants.hpp"

namespace {

using plumb::test::LogVariant;

void BM_ScanOdometryAccuracy(benchmark::State& state, const std::string& log_name, LogVariant variant, bool fuse) {
  plumb::test::ScanLog log;
  try {
    log = plumb::test::degrade(
        plumb::test::read_scan_log(plumb::bench::data_path("laser2d/carmen_corrected/" + log_name)), variant);
  } catch (const plumb::Error& e) {
    state.SkipWithError(e.what());
    return;
  }
  plumb::ScanOdometrySettings settings;
  settings.fuse_prior = fuse;
  plumb::ScanOdometryResult r;
  for (auto _ : state) {
    r = plumb::run_scan_odometry(log.scans, log.odometry, settings);
    benchmark::DoNotOptimize(r.poses.data());
  }
  const auto e1 = plumb::test::relation_error(r.poses, log.corrected, 1);
  const auto e10 = plumb::test::relation_error(r.poses, log.corrected, 10);
  const auto e50 = plumb::test::relation_error(r.poses, log.corrected, 50);
  const auto o1 = plumb::test::relation_error(log.odometry, log.corrected, 1);
  const auto o10 = plumb::test::relation_error(log.odometry, log.corrected, 10);
  const auto o50 = plumb::test::relation_error(log.odometry, log.corrected, 50);
  state.counters["t1_cm"] = e1.trans_cm;
  state.counters["r1_deg"] = e1.rot_deg;
  state.counters["t10_cm"] = e10.trans_cm;
  state.counters["r10_deg"] = e10.rot_deg;
  state.counters["t50_cm"] = e50.trans_cm;
  state.counters["r50_deg"] = e50.rot_deg;
  state.counters["odom_t1_cm"] = o1.trans_cm;
  state.counters["odom_r1_deg"] = o1.rot_deg;
  state.counters["odom_t10_cm"] = o10.trans_cm;
  state.counters["odom_r10_deg"] = o10.rot_deg;
  state.counters["odom_t50_cm"] = o50.trans_cm;
  state.counters["odom_r50_deg"] = o50.rot_deg;
  state.counters["prior_free"] = static_cast<double>(r.num_prior_free);
  state.counters["fallbacks"] = static_cast<double>(r.num_fallbacks);
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * log.scans.size()));
}

void register_all() {
  const std::string logs[] = {"intel-corrected.log.gz", "freiburg-079-corrected.log.gz",
                              "infinite-corridor-corrected.log.gz"};
  for (const std::string& log : logs) {
    const std::string short_name = log.substr(0, log.find('-'));
    for (const bool fuse : {false, true}) {
      for (LogVariant v : {LogVariant::kOriginal, LogVariant::kOneDegree, LogVariant::kSlip, LogVariant::kHeldOdometry}) {
        const std::string name = std::string(fuse ? "scan_odometry_accuracy_fused/" : "scan_odometry_accuracy/") +
                                 short_name + "/" + plumb::test::to_string(v);
        benchmark::RegisterBenchmark(name.c_str(), BM_ScanOdometryAccuracy, log, v, fuse)
            ->Iterations(1)
            ->Unit(benchmark::kMillisecond);
      }
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  register_all();
  return plumb::bench::run_benchmarks(argc, argv);
}
