#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# Accuracy suite of the BIM-corrected odometry: for each building, `plumb simulate` with the
# defaults (rfans32, two loops of the indoor route, as-built deviations σ 1 cm / 0.2°, furniture,
# range noise, wheel errors, motion distortion), then `plumb run` with the first frame localized in
# the building, and Table 2 of Liu et al. 2022 (end error of wheel odometry, LiDAR odometry and the
# BIM-corrected odometry as % of the distance) against the exact ground truth as one markdown table;
# then the same runs with the as-built estimate (`plumb run --as-built`): the trajectory's errors,
# and the deviation report's face offsets against the dump's as_built.json (the simulator's truth);
# and the second pass of those runs (`--refine`: every frame registered again to the building as
# estimated at the end of the run).
#
# usage: bash bench/accuracy.sh [PLUMB_BINARY] [OUT_DIR]
#   PLUMB_BINARY  default build/rel/examples/plumb (a Release build: `cmake --build build/rel`)
#   OUT_DIR       default /tmp/plumb_accuracy (dumps and run outputs stay there for inspection)
# Buildings: the demo office (examples/data), AC20-FZK-Haus and duplex from PLUMB_DATA_DIR
# (default ../shared/data), and a large office written by `plumb make-demo-building` (60 m x 15 m,
# 20 look-alike rooms off a 60 m corridor). duplex is two mirrored flats, so its run gets a start hint: the first
# ground-truth position rounded to the metre (its first frame, on the terrace in front of the
# facade, is then confirmed by the 3D overlap: BimLocalizerSettings::min_score_hinted).
set -euo pipefail
cd "$(dirname "$0")/.."
plumb="${1:-build/rel/examples/plumb}"
out="${2:-/tmp/plumb_accuracy}"
data="${PLUMB_DATA_DIR:-../shared/data}"
command -v python3 >/dev/null || { echo "accuracy.sh: needs python3 (apt-get install python3)" >&2; exit 1; }
[ -x "$plumb" ] || { echo "accuracy.sh: $plumb not found (build it first)" >&2; exit 1; }
mkdir -p "$out"

run_building() {  # name model [hinted]
  local name="$1" model="$2" start="${3:-}"
  "$plumb" simulate "$model" -o "$out/$name/dump" --threads "$(nproc)" --overwrite --json > "$out/$name/simulate.json"
  local extra=()
  if [ "$start" = hinted ]; then
    # gt.tum: a comment line, then "t x y z qx qy qz qw"
    read -r hx hy < <(awk '!/^#/ { printf "%.0f %.0f\n", $2, $3; exit }' "$out/$name/dump/gt.tum")
    extra=(--start-hint "$hx" "$hy")
  fi
  "$plumb" run "$out/$name/dump" --bim "$model" -o "$out/$name/run" --json "${extra[@]}" > "$out/$name/report.json" || true
  "$plumb" run "$out/$name/dump" --bim "$model" -o "$out/$name/run_as_built" --as-built --refine --json "${extra[@]}" \
    > "$out/$name/report_as_built.json" || true
}

for name in demo_office AC20-FZK-Haus duplex large_office; do mkdir -p "$out/$name"; done
"$plumb" make-demo-building -o "$out/large_office/large_office.ifc" --length 60 --width 15 --rooms 20 \
  --name "plumb large office" > /dev/null
run_building demo_office examples/data/demo_office.ifc
run_building AC20-FZK-Haus "$data/ifc/buildings/AC20-FZK-Haus.ifc"
run_building duplex "$data/ifc/buildings/duplex.ifc" hinted
run_building large_office "$out/large_office/large_office.ifc"

python3 - "$out" <<'PY'
import json, sys
out = sys.argv[1]
print("| building | path | start | start error | end error wheel / LiDAR / BIM | BIM better than LiDAR at every Table 2 point | max error LiDAR / BIM | APE LiDAR / BIM | BIM registration alone rms / max | frames/s (process) |")
print("|---|---|---|---|---|---|---|---|---|---|")
for name in ("demo_office", "AC20-FZK-Haus", "duplex", "large_office"):
    try:
        r = json.load(open(f"{out}/{name}/report.json"))
    except (OSError, ValueError):
        print(f"| {name} | run failed | | | | | | | | |"); continue
    if r.get("localization_status") != "ok":
        print(f"| {name} | – | not localized: {r.get('localization_status')} | | | | | | | |"); continue
    end = r["table"][-1]
    pct = lambda m: f"{100 * end[m]['error'] / end['distance']:.3f} %"
    start = "localized" if r["localized"] else "surveyed"
    reg = r["registration_error_xy"]
    print(f"| {name} | {end['distance']:.1f} m | {start} | {1000 * r['initial_error']['xy']:.1f} mm |"
          f" {pct('wheel')} / {pct('lidar')} / {pct('bim')} |"
          f" {'yes' if all(row['bim']['error'] < row['lidar']['error'] for row in r['table']) else 'no'} |"
          f" {100 * r['max_error_xy']['lidar']:.1f} / {100 * r['max_error_xy']['bim']:.1f} cm |"
          f" {100 * r['ape_rmse_xy']['lidar']:.1f} / {100 * r['ape_rmse_xy']['bim']:.1f} cm |"
          f" {100 * reg['rms']:.1f} / {100 * reg['max']:.1f} cm | {1 / r['mean_seconds_per_frame']['process']:.0f} |")
PY

python3 - "$out" <<'PY'
import json, statistics, sys
sys.path.insert(0, "bench")  # the script runs from the repository root
from as_built_datum import observed_faces
out = sys.argv[1]
print()
print("| building | max error BIM: design / as built / second pass | APE BIM: design / as built / second pass | registration rms: design / as built | end error BIM, as built / second pass | as built better than LiDAR at every Table 2 point: online / second pass | elements observed | offset error, median (sigma <= 5 mm) | deviates: flagged / right |")
print("|---|---|---|---|---|---|---|---|---|")
for name in ("demo_office", "AC20-FZK-Haus", "duplex", "large_office"):
    try:
        d = json.load(open(f"{out}/{name}/report.json"))
        a = json.load(open(f"{out}/{name}/report_as_built.json"))
        rows, faces = observed_faces(f"{out}/{name}/run_as_built", f"{out}/{name}/dump")
    except (OSError, ValueError, KeyError):
        print(f"| {name} | run failed | | | | | | | |"); continue
    errors = [abs(f["error"]) for f in faces if f["sigma"] <= 0.005]
    observed = len(faces)
    flagged = sum(f["status"] == "deviates" for f in faces)
    right = sum(f["status"] == "deviates" and abs(f["true"]) > rows["tolerance_m"] for f in faces)
    end = a["table"][-1]
    med = f"{1000 * statistics.median(errors):.1f} mm ({len(errors)})" if errors else "–"
    yes = lambda key: 'yes' if all(row[key]['error'] < row['lidar']['error'] for row in a['table']) else 'no'
    print(f"| {name} | {100 * d['max_error_xy']['bim']:.1f} / {100 * a['max_error_xy']['bim']:.1f} / {100 * a['max_error_xy']['bim_refined']:.1f} cm |"
          f" {100 * d['ape_rmse_xy']['bim']:.2f} / {100 * a['ape_rmse_xy']['bim']:.2f} / {100 * a['ape_rmse_xy']['bim_refined']:.2f} cm |"
          f" {100 * d['registration_error_xy']['rms']:.2f} / {100 * a['registration_error_xy']['rms']:.2f} cm |"
          f" {100 * end['bim']['error'] / end['distance']:.3f} / {100 * end['bim_refined']['error'] / end['distance']:.3f} % |"
          f" {yes('bim')} / {yes('bim_refined')} | {observed} of {len(rows['elements'])} | {med} | {flagged} / {right} |")
PY

# How much of the offsets' error is the datum (where the building as a whole stands in the design
# frame, which no measurement from inside can see): bench/as_built_datum.py.
echo
python3 bench/as_built_datum.py "$out"
