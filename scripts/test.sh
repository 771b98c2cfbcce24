#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# README command 2 (and CI): install what is missing; the layering and file-length check; release
# build with -Werror (library, CLI, examples, benchmarks, Python module) and the find_package
# consumer; the Python tests (pytest) on that build; the demo's steps of README command 1 on it;
# every test built and run under ASan+UBSan; each fuzzer for PLUMB_FUZZ_SECONDS (20), one per core
# at a time.
set -euo pipefail
cd "$(dirname "$0")/.."
root="$(pwd)"
jobs="$(nproc)"
fuzz_seconds="${PLUMB_FUZZ_SECONDS:-20}"

bash scripts/setup.sh --fuzz

# ccache (installed by setup.sh) makes rebuilds of unchanged sources free; harmless when cold.
launcher=()
if command -v ccache >/dev/null; then launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCMAKE_C_COMPILER_LAUNCHER=ccache); fi
# Paths under the clone hashed relative to it, so that a fresh clone elsewhere reuses the cache.
export CCACHE_BASEDIR="${CCACHE_BASEDIR:-$(pwd)}" CCACHE_NOHASHDIR="${CCACHE_NOHASHDIR:-1}"

data_dir="${PLUMB_DATA_DIR:-$root/../shared/data}"
if [ ! -f "$data_dir/SOURCES.md" ]; then
  echo "test.sh: data directory not found at $data_dir (set PLUMB_DATA_DIR)" >&2
  exit 1
fi
data_dir="$(cd "$data_dir" && pwd)"
export PLUMB_DATA_DIR="$data_dir"
# The interpreter setup.sh installs numpy and pytest for (apt's), whatever python3 comes first on PATH.
python=/usr/bin/python3

start_time=$SECONDS
step() { echo; echo "== [$((SECONDS - start_time)) s] $*"; }

step "house rules a compiler does not check: layering and file lengths (scripts/check_layering.py)"
python3 scripts/check_layering.py

step "release build (-Werror): library, CLI, examples, benchmarks, Python module"
cmake -S . -B build/ci "${launcher[@]}" -DCMAKE_BUILD_TYPE=Release -DPLUMB_WERROR=ON -DPLUMB_DATA_DIR="$data_dir" \
      -DPLUMB_BUILD_TESTS=OFF -DPLUMB_BUILD_BENCH=ON -DPLUMB_BUILD_EXAMPLES=ON -DPLUMB_BUILD_PYTHON=ON \
      -DPython3_EXECUTABLE="$python" -DCMAKE_INSTALL_PREFIX="$root/build/ci/prefix" >/dev/null
cmake --build build/ci -j"$jobs"

step "Python tests (pytest) on the release build"
PYTHONPATH="$root/build/ci/python" PLUMB_CLI="$root/build/ci/examples/plumb" \
  "$python" -m pytest -q -p no:cacheprovider python/tests

step "package: install, then consumers that find_package(plumb) and link one component each"
rm -rf build/ci/prefix build/package
cmake --install build/ci >/dev/null
cmake -S tests/package -B build/package -DCMAKE_PREFIX_PATH="$root/build/ci/prefix" >/dev/null
cmake --build build/package -j"$jobs"
# The installed Python package imports from the prefix's site directory.
python_site="$(sed -n 's/^PLUMB_PYTHON_INSTALL_DIR:PATH=//p' build/ci/CMakeCache.txt)"
case "$python_site" in /*) ;; *) python_site="$root/build/ci/prefix/$python_site" ;; esac
PYTHONPATH="$python_site" "$python" -c "import plumb; assert plumb.__file__.startswith('$python_site')"
for component in plumb core io bim sim pipeline app; do
  consumer=build/package/plumb_consumer
  [ "$component" = plumb ] || consumer="build/package/plumb_${component}_consumer"
  "$consumer"
done
# plumb::core needs nothing but Eigen: its consumer links neither zlib nor liblzf.
if grep -Eq '(libz\.|-lz( |$)|lzf)' build/package/CMakeFiles/plumb_core_consumer.dir/link.txt; then
  echo "test.sh: plumb::core's consumer links zlib or liblzf:" >&2
  cat build/package/CMakeFiles/plumb_core_consumer.dir/link.txt >&2
  exit 1
fi
# plumb::sim reads and writes no file: its consumer does not link plumb::io.
if grep -q 'plumb_io' build/package/CMakeFiles/plumb_sim_consumer.dir/link.txt; then
  echo "test.sh: plumb::sim's consumer links plumb::io:" >&2
  cat build/package/CMakeFiles/plumb_sim_consumer.dir/link.txt >&2
  exit 1
fi

step "README command 1's demo steps on this build (scripts/run_demo.sh)"
# The same script scripts/demo.sh ends with: if a new user's first command would fail, CI fails.
bash scripts/run_demo.sh build/ci build/ci/demo

step "ASan + UBSan build (-Werror): library, CLI, every test"
# The test suite is compiled once, with the sanitizers, and every test runs under ASan + UBSan: a
# second (release) build and run of the same tests took a third of CI's time on two cores.
# -O1 without -g: sanitizers need no debug info to name the failing function, and Eigen-heavy
# sources compile several times faster; NDEBUG stays undefined so Eigen's own asserts run too.
# PLUMB_UNITY_TESTS: each test binary's files compiled as one unit (gtest and Eigen parsed once).
cmake -S . -B build/asan "${launcher[@]}" -DCMAKE_BUILD_TYPE=None -DCMAKE_CXX_FLAGS="-O1" -DPLUMB_SANITIZE=ON -DPLUMB_WERROR=ON \
      -DPLUMB_DATA_DIR="$data_dir" -DPLUMB_BUILD_TESTS=ON -DPLUMB_BUILD_BENCH=OFF \
      -DPLUMB_BUILD_EXAMPLES=ON -DPLUMB_UNITY_TESTS=ON >/dev/null
cmake --build build/asan -j"$jobs"

if [ "$fuzz_seconds" -gt 0 ]; then
  step "fuzzers, ${fuzz_seconds} s each, ${jobs} at a time"
  cmake -S . -B build/fuzz "${launcher[@]}" -DCMAKE_BUILD_TYPE=None -DCMAKE_CXX_FLAGS="-O1" -DCMAKE_CXX_COMPILER=clang++ \
        -DPLUMB_BUILD_FUZZERS=ON -DPLUMB_BUILD_TESTS=OFF -DPLUMB_BUILD_BENCH=OFF \
        -DPLUMB_BUILD_EXAMPLES=OFF >/dev/null
  cmake --build build/fuzz -j"$jobs" --target plumb_fuzzers
  # Plain-text seeds for the CARMEN parser: the first lines of each message type of the shared
  # logs, inflated into the build tree (the repository keeps only hand-written seeds).
  mkdir -p build/fuzz/seeds_carmen
  for log in "$data_dir"/laser2d/carmen_corrected/*.log.gz; do
    gzip -dc "$log" | awk 'seen[$1]++ < 4' > "build/fuzz/seeds_carmen/$(basename "$log" .gz)"
  done
  # One fuzzer per core at a time; each writes its own log, printed (tail) in name order after.
  fuzz_one() {
    local fuzzer="$1" name target corpus
    name="$(basename "$fuzzer")"
    target="${name#plumb_}"
    target="${target%_fuzz}"
    corpus="build/fuzz/corpus_$name"
    mkdir -p "$corpus"
    local seeds=() options=()
    [ -d "fuzz/seeds/$target" ] && seeds+=("fuzz/seeds/$target")
    # Seeds read from the shared data. Where its files are large, inputs are capped at 16 KiB
    # (libFuzzer cuts longer seeds to that): a file's first lines cover the reader as well as all
    # of it, at a hundred times the executions per second.
    case "$target" in
      carmen) seeds+=(build/fuzz/seeds_carmen) ;;
      carmen_gz) seeds+=("$data_dir/laser2d/carmen_corrected") ;;
      calib_tuples) seeds+=("$data_dir/laser2d/calibration_censi"); options+=(-max_len=16384) ;;
      trajectory) seeds+=("$data_dir/trajectories/kitti00"); options+=(-max_len=16384) ;;
    esac
    local status=0
    "$fuzzer" -max_total_time="$fuzz_seconds" -rss_limit_mb=2048 -print_final_stats=1 ${options[@]+"${options[@]}"} \
      "$corpus" ${seeds[@]+"${seeds[@]}"} > "build/fuzz/$name.log" 2>&1 || status=$?
    echo "$status" > "build/fuzz/$name.status"
  }
  fuzzers=()
  for fuzzer in build/fuzz/fuzz/plumb_*_fuzz; do [ -x "$fuzzer" ] && fuzzers+=("$fuzzer"); done
  rm -f build/fuzz/*.status
  for fuzzer in "${fuzzers[@]}"; do
    while [ "$(jobs -rp | wc -l)" -ge "$jobs" ]; do wait -n || true; done
    fuzz_one "$fuzzer" &
  done
  wait
  fuzz_failed=0
  for fuzzer in "${fuzzers[@]}"; do
    name="$(basename "$fuzzer")"
    status="$(cat "build/fuzz/$name.status" 2>/dev/null || echo missing)"
    echo "-- $name (exit $status)"
    tail -n 12 "build/fuzz/$name.log"
    [ "$status" = 0 ] || fuzz_failed=1
  done
  if [ "$fuzz_failed" -ne 0 ]; then
    echo "test.sh: a fuzzer failed (its log is above and in build/fuzz/)" >&2
    exit 1
  fi
fi

step "tests (ASan + UBSan)"
cd build/asan
ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1 \
  ctest -j"$jobs" --output-on-failure --timeout 900 | tee ctest.log
total="$(grep -oE 'tests failed out of [0-9]+' ctest.log | grep -oE '[0-9]+$')"
failed="$(grep -oE '[0-9]+ tests failed out of' ctest.log | grep -oE '^[0-9]+')"
echo "test.sh: done in $((SECONDS - start_time)) s"
skipped="$(grep -cE '^[[:space:]]+[0-9]+ - .*\(Skipped\)$' ctest.log || true)"
echo "tests: $((total - failed - skipped)) passed, ${failed} failed, ${skipped} skipped"
