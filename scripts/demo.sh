#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# README command 1: install what is missing, build (release), and run the demo to its end
# (scripts/run_demo.sh, the same steps CI runs in scripts/test.sh).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
launcher=()
if command -v ccache >/dev/null; then launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCMAKE_C_COMPILER_LAUNCHER=ccache); fi
# Paths under the clone hashed relative to it, so that a fresh clone elsewhere reuses the cache.
export CCACHE_BASEDIR="${CCACHE_BASEDIR:-$(pwd)}" CCACHE_NOHASHDIR="${CCACHE_NOHASHDIR:-1}"
cmake -S . -B build/release "${launcher[@]}" -DCMAKE_BUILD_TYPE=Release -DPLUMB_BUILD_TESTS=OFF \
      -DPLUMB_BUILD_BENCH=OFF -DPLUMB_BUILD_EXAMPLES=ON >/dev/null
cmake --build build/release -j"$(nproc)"
bash scripts/run_demo.sh build/release
