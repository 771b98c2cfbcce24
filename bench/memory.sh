#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# Peak resident memory of plumb run and plumb lio against the length of the run: the demo office's
# route driven once and twice (VLP-16, seed 2), and a FZK-Haus site run of growing length. Prints
# the peak_rss_mib of each report.json.
set -euo pipefail
cd "$(dirname "$0")/.."
P=${1:-build/rel/examples/plumb}
OUT=${2:-/tmp/plumb_memory}
FZK=${PLUMB_DATA_DIR:-../shared/data}/ifc/buildings/AC20-FZK-Haus.ifc
OFFICE=examples/data/demo_office.ifc
mkdir -p "$OUT"
peak() { python3 -c "import json, sys; print(json.load(open(sys.argv[1]))['peak_rss_mib'])" "$1/report.json"; }
for loops in 1 2; do
  d="$OUT/office_loops$loops"
  [ -d "$d" ] || "$P" simulate "$OFFICE" -o "$d" --lidar vlp16 --loops "$loops" --seed 2 > /dev/null
  "$P" run "$d" --bim "$OFFICE" --gt-start --threads 1 -o "$d.run" --overwrite > /dev/null
  "$P" lio "$d" --mode hybrid --threads 1 -o "$d.lio" --overwrite > /dev/null
  echo "office, $loops loop(s), $(python3 -c "import json; print(json.load(open('$d.run/report.json'))['frames'])") frames: run $(peak "$d.run") MiB, lio $(peak "$d.lio") MiB"
done
for length in 40 80 160 320; do
  d="$OUT/site_$length"
  [ -d "$d" ] || "$P" simulate "$FZK" -o "$d" --scenario site --length "$length" --seed 2 > /dev/null
  "$P" lio "$d" --mode hybrid --threads 1 -o "$d.lio" --overwrite > /dev/null
  "$P" lio "$d" --mode hybrid --threads 1 --map-window 100 -o "$d.lio100" --overwrite > /dev/null
  echo "site, $length m: lio $(peak "$d.lio") MiB, lio --map-window 100 $(peak "$d.lio100") MiB"
done
