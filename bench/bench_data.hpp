// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Where benchmarks find the shared data: env PLUMB_DATA_DIR, else the CMake cache value
/// compiled in (see shared/data/SOURCES.md).

#include <cstddef>
#include <cstdlib>
#include <string>

#include <benchmark/benchmark.h>

#include "build_tree.hpp"

#include <dlfcn.h>

/// @brief `fn` where PCL is built, else nullptr: the peer argument of register_with_peers().
#ifdef PLUMB_BENCH_HAVE_PCL
#define PLUMB_BENCH_PCL(fn) (fn)
#else
#define PLUMB_BENCH_PCL(fn) nullptr
#endif

/// @brief `fn` where Open3D is built, else nullptr: the peer argument of register_with_peers().
#ifdef PLUMB_BENCH_HAVE_OPEN3D
#define PLUMB_BENCH_OPEN3D(fn) (fn)
#else
#define PLUMB_BENCH_OPEN3D(fn) nullptr
#endif

namespace plumb::bench {

/// @brief PLUMB_DATA_DIR, else the build tree's CMake cache variable of that name (build_tree.hpp).
inline std::string data_dir() { return test::data_dir(); }

/// @brief Absolute path of a file under the data directory.
inline std::string data_path(const std::string& relative) { return data_dir() + "/" + relative; }

/// @brief Set the number of OpenMP threads (used by Open3D and PCL's OMP estimators); peers run
///        single-threaded like plumb unless a benchmark says otherwise. libgomp reads
///        OMP_NUM_THREADS when it loads, before main(), so this calls omp_set_num_threads through
///        the already loaded runtime instead (no-op without OpenMP).
inline void openmp_threads(int threads) {
  using SetFn = void (*)(int);
  if (void* sym = dlsym(RTLD_DEFAULT, "omp_set_num_threads")) reinterpret_cast<SetFn>(sym)(threads);
}
inline void single_thread_openmp() { openmp_threads(1); }

/// @brief True when an OpenMP runtime is loaded (a peer's threads: variants mean something).
inline bool have_openmp() { return dlsym(RTLD_DEFAULT, "omp_set_num_threads") != nullptr; }

/// @brief Runs `fn` (a peer's single-thread benchmark that parallelises with OpenMP, as Open3D
///        does) on `threads` OpenMP threads, then puts OpenMP back to one thread.
inline void with_openmp_threads(benchmark::State& state, int threads, void (*fn)(benchmark::State&)) {
  openmp_threads(threads);
  fn(state);
  openmp_threads(1);
}

/// @brief Times a sequential estimator frame by frame: `step(i)` processes frame i, for i = first,
///        first + 1, ... n - 1 in order; at the end `restart()` (untimed) makes a fresh estimator and
///        the frames start again at `first`. Call restart() once before. Sets items_per_second =
///        frames/s and returns the number of frames timed.
template <class Restart, class Step>
std::size_t time_frames_in_order(benchmark::State& state, std::size_t first, std::size_t n, Restart&& restart,
                                 Step&& step) {
  std::size_t next = first, frames = 0;
  for (auto _ : state) {
    if (next == n) {
      state.PauseTiming();
      restart();
      state.ResumeTiming();
      next = first;
    }
    step(next++);
    ++frames;
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(frames));
  return frames;
}

/// @brief A benchmark function without arguments.
using BenchmarkFn = void (*)(benchmark::State&);

/// @brief Registers `fn` as benchmark `name`, reported in milliseconds.
inline void register_ms(const std::string& name, BenchmarkFn fn) {
  benchmark::RegisterBenchmark(name.c_str(), fn)->Unit(benchmark::kMillisecond);
}

/// @brief A benchmark function given a thread count.
using ThreadsBenchmarkFn = void (*)(benchmark::State&, int);

/// @brief Registers `name`/threads:N for N = 1, 2, 4 and 8, timed by the wall clock (the work is
///        spread over threads), in milliseconds: the speed-up of a parallel stage by thread count.
inline void register_threads(const std::string& name, ThreadsBenchmarkFn fn) {
  for (int threads : {1, 2, 4, 8}) {
    benchmark::RegisterBenchmark((name + "/threads:" + std::to_string(threads)).c_str(), fn, threads)
        ->Unit(benchmark::kMillisecond)
        ->UseRealTime();
  }
}

/// @brief Registers `op`/plumb/`dataset`, then `op`/pcl/`dataset` and `op`/open3d/`dataset` for the
///        peers that are built (pass PLUMB_BENCH_PCL(fn) and PLUMB_BENCH_OPEN3D(fn): nullptr without
///        the peer), all in milliseconds.
inline void register_with_peers(const std::string& op, const std::string& dataset, BenchmarkFn plumb_fn,
                                BenchmarkFn pcl_fn, BenchmarkFn open3d_fn) {
  register_ms(op + "/plumb/" + dataset, plumb_fn);
  if (pcl_fn != nullptr) register_ms(op + "/pcl/" + dataset, pcl_fn);
  if (open3d_fn != nullptr) register_ms(op + "/open3d/" + dataset, open3d_fn);
}

/// @brief The end of a benchmark main() once everything is registered: reads the command line,
///        runs the benchmarks it selects and returns main()'s exit code (1 on an unknown argument).
inline int run_benchmarks(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}

}  // namespace plumb::bench
