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

# The main job on the built-in sample: a robot simulated in the demo office (examples/data), then the
# BIM-corrected odometry over its frames, with the seed's Table 2 against the exact ground truth.
demo_dir="build/release/demo"
rm -rf "$demo_dir"
mkdir -p "$demo_dir"
echo
echo "== plumb simulate examples/data/demo_office.ifc (20 m, rfans32)"
./build/release/examples/plumb simulate examples/data/demo_office.ifc -o "$demo_dir/dump" --length 20 --threads "$(nproc)"
echo
echo "== plumb run (BIM-corrected odometry; trajectories and trajectory.svg in $demo_dir/run)"
./build/release/examples/plumb run "$demo_dir/dump" --bim examples/data/demo_office.ifc -o "$demo_dir/run" --gt-start
