// SPDX-License-Identifier: BSD-3-Clause
// IFC parse + mesh and BIM-cloud sampling. The web-ifc peer (node) is timed by
// scripts/ifc_golden/webifc_bbox.cjs --time N on the same files; see bench/README.md for the ratio.

#include <benchmark/benchmark.h>

#include <fstream>
#include <sstream>
#include <string>
#include <utility>

#include "bench_data.hpp"
#include "plumb/bim/mesh.hpp"
#include "plumb/bim/sample.hpp"

namespace {

std::string slurp(const std::string& relative) {
  std::ifstream in(plumb::bench::data_path(relative), std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

void parse_only(benchmark::State& state, const std::string& relative) {
  const std::string text = slurp(relative);
  if (text.empty()) {
    state.SkipWithError("data file missing");
    return;
  }
  for (auto _ : state) {
    auto model = plumb::bim::parse_ifc(text, relative);
    benchmark::DoNotOptimize(model.step.size());
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations()));
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * text.size()));
}

void parse_and_mesh(benchmark::State& state, const std::string& relative) {
  const std::string text = slurp(relative);
  if (text.empty()) {
    state.SkipWithError("data file missing");
    return;
  }
  std::size_t triangles = 0;
  for (auto _ : state) {
    const auto model = plumb::bim::parse_ifc(text, relative);
    const auto mesh = plumb::bim::build_mesh(model);
    triangles = mesh.num_triangles();
    benchmark::DoNotOptimize(triangles);
  }
  state.counters["triangles"] = static_cast<double>(triangles);
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations()));
}

void sample_2cm(benchmark::State& state, const std::string& relative) {
  const std::string text = slurp(relative);
  if (text.empty()) {
    state.SkipWithError("data file missing");
    return;
  }
  const auto mesh = plumb::bim::build_mesh(plumb::bim::parse_ifc(text, relative));
  plumb::bim::SurfaceSampleSettings settings;
  settings.spacing = 0.02;
  std::size_t points = 0;
  for (auto _ : state) {
    const auto cloud = plumb::bim::sample_surface(mesh, settings);
    points = cloud.size();
    benchmark::DoNotOptimize(points);
  }
  state.counters["points"] = static_cast<double>(points);
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * points));
}

}  // namespace

int main(int argc, char** argv) {
  const std::string fzk = "ifc/buildings/AC20-FZK-Haus.ifc";
  const std::string duplex = "ifc/buildings/duplex.ifc";
  for (const auto& [name, file] : {std::pair{"fzk_haus", fzk}, std::pair{"duplex", duplex}}) {
    benchmark::RegisterBenchmark((std::string("ifc_parse/plumb/") + name).c_str(), parse_only, file)
        ->Unit(benchmark::kMillisecond);
    benchmark::RegisterBenchmark((std::string("ifc_parse_mesh/plumb/") + name).c_str(), parse_and_mesh, file)
        ->Unit(benchmark::kMillisecond);
    benchmark::RegisterBenchmark((std::string("bim_sample_2cm/plumb/") + name).c_str(), sample_2cm, file)
        ->Unit(benchmark::kMillisecond);
  }
  return plumb::bench::run_benchmarks(argc, argv);
}
