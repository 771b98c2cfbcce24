#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# Accuracy suite of the LiDAR/IMU odometry (Zhou et al. 2021): for each building and noise seed,
# `plumb simulate --scenario site` (a VLP-16 robot driving around the building and out into the
# open, ~340-390 m, exact ground truth), then `plumb lio` in the three modes with a 150-frame map
# window (no implicit loop closure, like the runs of Zhou et al. 2021), and one markdown table of
# the mean translational RPE over 10 m and the end error (from plumb lio's report, against the dump's exact
# gt.tum), with the hybrid's ratios to LiDAR only and to LOAM + IMU (targets: hybrid RPE <= 0.67 of
# LiDAR only's and <= 0.89 of LOAM + IMU's, hybrid end error <= 0.2 of LiDAR only's).
#
# usage: bash bench/lio_site.sh [PLUMB_BINARY] [OUT_DIR] [SEED...]
#   PLUMB_BINARY  default build/rel/examples/plumb (a Release build: `cmake --build build/rel`)
#   OUT_DIR       default /tmp/plumb_lio_site (dumps, trajectories and reports stay there)
#   SEED...       default 1 2 3 4 5
# Environment: PLUMB_DATA_DIR (default ../shared/data), JOBS (parallel `plumb lio` runs, default 2),
# MAP_WINDOW (default 150; 0 gives the default 60 m maps, which close loops implicitly), MAX_FRAMES
# (only the first N frames of each dump: a quick check of the suite itself, not a measurement).
# Time: about 3-6 minutes per run on one core, so the default 30 runs take 1-1.5 hours on 2 cores.
set -euo pipefail
repo="$(cd "$(dirname "$0")/.." && pwd)"
plumb="$(realpath -m "${1:-$repo/build/rel/examples/plumb}")"
out="$(realpath -m "${2:-/tmp/plumb_lio_site}")"
data="$(realpath -m "${PLUMB_DATA_DIR:-$repo/../shared/data}")"
shift $(( $# > 2 ? 2 : $# ))
seeds=("$@")
[ ${#seeds[@]} -gt 0 ] || seeds=(1 2 3 4 5)
jobs="${JOBS:-2}"
window="${MAP_WINDOW:-150}"
command -v python3 >/dev/null || { echo "lio_site.sh: needs python3 (apt-get install python3)" >&2; exit 1; }
[ -x "$plumb" ] || { echo "lio_site.sh: $plumb not found (build it first)" >&2; exit 1; }
mkdir -p "$out"

declare -A model=([fzk]="$data/ifc/buildings/AC20-FZK-Haus.ifc" [duplex]="$data/ifc/buildings/duplex.ifc")
runs=()
for b in fzk duplex; do
  for s in "${seeds[@]}"; do
    dump="$out/${b}_$s/dump"
    mkdir -p "$out/${b}_$s"
    if [ ! -f "$dump/gt.tum" ]; then  # dumps are kept between runs of the suite
      "$plumb" simulate "${model[$b]}" -o "$dump" --scenario site --seed "$s" --overwrite > "$out/${b}_$s/simulate.txt"
    fi
    for m in loam loam-imu hybrid; do runs+=("$out/${b}_$s $m"); done
  done
done

# One `plumb lio` per line of runs (RUN MODE, appended as $3 $4), JOBS at a time; each writes
# RUN/MODE/{trajectory.tum,report.json} and its JSON report to RUN/MODE.json. OUT_DIR must not hold spaces.
printf '%s\n' "${runs[@]}" | xargs -P "$jobs" -L1 sh -c \
  'OMP_NUM_THREADS=1 "$0" lio "$3/dump" --mode "$4" --map-window "$1" ${2:+--max-frames "$2"} -o "$3/$4" --json \
     > "$3/$4.json" 2> "$3/$4.err" || echo "lio_site.sh: plumb lio $3 --mode $4 failed (see $3/$4.err)" >&2' \
  "$plumb" "$window" "${MAX_FRAMES:-}"

python3 - "$out" "${seeds[@]}" <<'PY'
import json, sys
out, seeds = sys.argv[1], sys.argv[2:]

def report(run, mode):  # plumb lio's report: RPE over 10 m and end error against the dump's gt.tum
    try:
        r = json.load(open(f"{run}/{mode}.json"))
        # No rpe_10m when the run is shorter than 10 m (MAX_FRAMES): NaN, and the ratios say so.
        return r.get("rpe_10m", {}).get("translation_mean", float("nan")), r["end_error"], r["frames_per_mode"]
    except (OSError, KeyError, ValueError):
        return None

print("| building, seed | LiDAR only (loam) | loam-imu | hybrid (ICP frames) | hybrid / loam RPE, end | hybrid / loam-imu RPE, end |")
print("|---|---|---|---|---|---|")
worst = [0.0, 0.0, 0.0]
for b in ("fzk", "duplex"):
    for s in seeds:
        run = f"{out}/{b}_{s}"
        m = {mode: report(run, mode) for mode in ("loam", "loam-imu", "hybrid")}
        if any(v is None for v in m.values()):
            print(f"| {b}, {s} | (a run failed: see {run}/*.err) | | | | |")
            continue
        (lr, le, lf), (ir, ie, _), (hr, he, hf) = m["loam"], m["loam-imu"], m["hybrid"]
        lost = f", {lf['prediction']} frames predicted" if lf["prediction"] else ""
        worst = [max(worst[0], hr / lr), max(worst[1], hr / ir), max(worst[2], he / le)]
        print(f"| {b}, {s} | {lr:.3f} m / {le:.2f} m{lost} | {ir:.3f} m / {ie:.2f} m | {hr:.3f} m / {he:.2f} m ({hf['icp']}) "
              f"| {hr / lr:.3f}, {he / le:.3f} | {hr / ir:.3f}, {he / ie:.3f} |")
print(f"\nWorst ratios: hybrid / loam RPE {worst[0]:.3f} (target <= 0.67), hybrid / loam-imu RPE {worst[1]:.3f} "
      f"(target <= 0.89), hybrid / loam end error {worst[2]:.3f} (target <= 0.2).")
PY
