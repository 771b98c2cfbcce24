#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# The demo's steps on an existing build: what README command 1 (scripts/demo.sh) shows a new user,
# and what CI (scripts/test.sh) runs on its own release build, so the two cannot drift apart.
#   scripts/run_demo.sh BUILD_DIR [OUT_DIR]      (OUT_DIR defaults to BUILD_DIR/demo, made afresh)
# Every step must exit 0; the script ends with the demo's accuracy table and its trajectory.svg.
set -euo pipefail
if [ $# -lt 1 ] || [ $# -gt 2 ]; then
  echo "usage: $0 BUILD_DIR [OUT_DIR]" >&2
  exit 2
fi
build="$1"
if [ $# -eq 2 ]; then
  out="$2"
else
  # The default output lives in the build tree, which is ours: start it afresh (plumb demo refuses
  # a directory holding anything it did not write itself).
  out="$build/demo"
  rm -rf "$out"
fi
plumb="$build/examples/plumb"
if [ ! -x "$plumb" ]; then
  echo "run_demo.sh: $plumb not found (build with -DPLUMB_BUILD_EXAMPLES=ON)" >&2
  exit 1
fi
threads="$(nproc)"
log="$(mktemp)"
trap 'rm -f "$log"' EXIT

echo
echo "== plumb --help"
"$plumb" --help

echo
echo "== plumb_example_01_cloud_basics (clouds, voxel grid, kd-tree, PCD, SE(2) poses)"
"$build/examples/plumb_example_01_cloud_basics"

# The main job on the built-in sample: `plumb demo` writes the demo office (IFC4), simulates a robot
# driving two loops through it, localizes its first frame in the model, runs the BIM-corrected
# odometry and prints the accuracy table against the exact ground truth (trajectory.svg beside it).
echo
echo "== plumb demo -o $out"
"$plumb" demo -o "$out" --threads "$threads" | tee "$log"

# The same job written as a robot's own loop with the library: the demo's model and frame dump fed
# one frame at a time into BimLocalizer and BimOdometry.
echo
echo "== plumb_example_02_bim_odometry $out/demo_office.ifc $out/dump"
"$build/examples/plumb_example_02_bim_odometry" "$out/demo_office.ifc" "$out/dump"

echo
echo "== the demo's result"
sed -n '/BIM-corrected odometry done/,$p' "$log" | sed '1d'
svg="$out/run/trajectory.svg"
if [ ! -s "$svg" ]; then
  echo "run_demo.sh: $svg was not written" >&2
  exit 1
fi
echo "trajectory plot: $(cd "$(dirname "$svg")" && pwd)/$(basename "$svg") (open it in a browser)"
