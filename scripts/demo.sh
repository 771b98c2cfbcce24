#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# README command 1: install what is missing, build, and run the demo.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
cmake -S . -B build/release -DCMAKE_BUILD_TYPE=Release -DPLUMB_BUILD_TESTS=OFF -DPLUMB_BUILD_BENCH=OFF \
      -DPLUMB_BUILD_EXAMPLES=ON >/dev/null
cmake --build build/release -j"$(nproc)"
echo
echo "== plumb --help"
./build/release/examples/plumb --help
for example in build/release/examples/plumb_example_*; do
  [ -x "$example" ] || continue
  echo
  echo "== $(basename "$example")"
  "$example"
done

# The main job on the built-in sample: `plumb demo` writes the demo office (IFC4), simulates a robot
# driving two loops through it, localizes its first frame in the model, runs the BIM-corrected
# odometry and prints the seed's Table 2 against the exact ground truth (trajectory.svg beside it).
echo
echo "== plumb demo"
./build/release/examples/plumb demo -o build/release/demo --threads "$(nproc)"
