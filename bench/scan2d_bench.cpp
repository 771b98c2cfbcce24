// SPDX-License-Identifier: BSD-3-Clause
// PLICP speed: ms per match on consecutive scans of the intel-corrected CARMEN log (180 beams),
// with the raw-odometry prior as first guess, as in scan-matching odometry. And the correlative
// (branch-and-bound) global search the BIM localizer runs: one intel scan against a 5 cm map of
// the first 400 corrected scans, every heading, every translation.

#include <string>
#include <vector>

#include <benchmark/benchmark.h>

#include "bench_data.hpp"
#include "plumb/io/carmen.hpp"
#include "plumb/scan2d/correlative.hpp"
#include "plumb/scan2d/plicp.hpp"

namespace {

struct Pairs {
  std::vector<plumb::PlicpReference> refs;
  std::vector<std::vector<plumb::Vector2d>> currents;
  std::vector<plumb::Pose2> guesses;
};

const Pairs* load(const std::string& name) {
  static Pairs pairs;
  static bool loaded = false;
  if (loaded) return pairs.refs.empty() ? nullptr : &pairs;
  loaded = true;
  try {
    const auto log = plumb::io::read_carmen(plumb::bench::data_path("laser2d/carmen_corrected/" + name));
    const auto odom = plumb::io::raw_odometry_at_lasers(log);
    for (std::size_t k = 1; k < log.lasers.size(); ++k) {
      pairs.refs.emplace_back(log.lasers[k - 1].scan);
      pairs.currents.push_back(log.lasers[k].scan.to_points());
      pairs.guesses.push_back(odom[k - 1].ominus().oplus(odom[k]));
    }
  } catch (const plumb::Error&) {
    return nullptr;
  }
  return &pairs;
}

void BM_PlicpIntel(benchmark::State& state) {
  const Pairs* p = load("intel-corrected.log.gz");
  if (p == nullptr) {
    state.SkipWithError("intel-corrected.log.gz not found (PLUMB_DATA_DIR)");
    return;
  }
  std::size_t k = 0;
  for (auto _ : state) {
    const auto r = plumb::plicp(p->currents[k], p->refs[k], p->guesses[k]);
    benchmark::DoNotOptimize(r.T_ref_cur.x);
    k = (k + 1) % p->refs.size();
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));
}
BENCHMARK(BM_PlicpIntel)->Name("plicp/plumb/intel")->Unit(benchmark::kMillisecond);

void BM_CorrelativeGlobalIntel(benchmark::State& state) {
  static std::vector<plumb::Vector2d> map_points;
  static std::vector<std::vector<plumb::Vector2d>> scans;
  if (scans.empty()) {
    try {
      const auto log = plumb::io::read_carmen(plumb::bench::data_path("laser2d/carmen_corrected/intel-corrected.log.gz"));
      for (std::size_t k = 0; k < log.lasers.size() && k < 400; ++k) {
        for (const plumb::Vector2d& p : log.lasers[k].scan.to_points()) map_points.push_back(log.lasers[k].pose * p);
        if (k % 40 == 20) scans.push_back(log.lasers[k].scan.to_points());
      }
    } catch (const plumb::Error&) {
    }
  }
  if (scans.empty()) {
    state.SkipWithError("intel-corrected.log.gz not found (PLUMB_DATA_DIR)");
    return;
  }
  plumb::CorrelativeMapSettings map_settings;
  map_settings.resolution = 0.05;
  const plumb::CorrelativeMap2D map(map_points, map_settings);
  std::size_t nodes = 0;
  for (auto _ : state) {  // one iteration: every scan once, so each run times the same work
    for (const auto& scan : scans) {
      const plumb::CorrelativeResult r = map.match(scan);
      nodes += r.nodes_scored;
      benchmark::DoNotOptimize(r.pose.x);
    }
  }
  const double matches = static_cast<double>(state.iterations() * scans.size());
  state.counters["nodes_per_match"] = static_cast<double>(nodes) / matches;
  state.SetItemsProcessed(static_cast<int64_t>(matches));
}
BENCHMARK(BM_CorrelativeGlobalIntel)->Name("correlative_global/plumb/intel")->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
