#!/usr/bin/env python3
# SPDX-License-Identifier: BSD-3-Clause
"""How much of the as-built offsets' error is the datum: the error of the face offsets that
`plumb run --as-built` reports against the simulator's truth, as measured by bench/accuracy.sh, and
the same after removing the one horizontal shift common to all observed elements that fits the
errors best (least squares over the observed rows), beside the shift the datum predicts: minus the
mean true displacement of the observed faces.

A robot inside a building measures its elements against each other; where the building as a whole
stands against the design frame is fixed only by the estimate's prior (every element zero-mean).
The simulator displaces each element independently, so the mean displacement of the elements a run
sees is not zero (about sigma / sqrt(N) for N elements) and no estimate from inside can see it.

usage: python3 bench/as_built_datum.py OUT_DIR   (the OUT_DIR of bench/accuracy.sh)
"""
import json
import statistics
import sys


def observed_faces(run_dir, dump_dir):
    """The deviation report of a run against the dump's truth: (rows, faces), with `rows` the report
    as read (`tolerance_m`, `elements`) and one face per observed element: normal, error (estimated
    minus true offset), sigma, status, true (the true offset) and moved (the true displacement of the
    face point). Also used by bench/accuracy.sh."""
    rows = json.load(open(f"{run_dir}/deviations.json"))
    truth = {e["global_id"]: e["T_design_asbuilt"] for e in json.load(open(f"{dump_dir}/as_built.json"))["elements"]}
    faces = []
    for row in rows["elements"]:
        if row["status"] == "unobserved":
            continue
        T, p, n = truth[row["global_id"]], row["point"], row["normal"]
        moved = [sum(T[4 * i + j] * p[j] for j in range(3)) + T[4 * i + 3] - p[i] for i in range(3)]
        true = sum(n[i] * moved[i] for i in range(3))
        faces.append({"normal": n, "error": row["offset_m"] - true, "sigma": row["sigma_m"],
                      "status": row["status"], "true": true, "moved": moved})
    return rows, faces


def common_shift(errors):
    """The horizontal shift d minimising sum (error - n_xy . d)^2 (2x2 normal equations)."""
    a = b = c = u = v = 0.0
    for f in errors:
        n, e = f["normal"], f["error"]
        a += n[0] * n[0]
        b += n[0] * n[1]
        c += n[1] * n[1]
        u += n[0] * e
        v += n[1] * e
    det = a * c - b * b
    if abs(det) < 1e-9 * max(1.0, a * c):  # all normals parallel: only the shift along them
        return ((u / a, 0.0) if a > 0 else (0.0, v / c if c > 0 else 0.0))
    return ((c * u - b * v) / det, (a * v - b * u) / det)


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    out = sys.argv[1]
    print("| building | offset error, median (sigma <= 5 mm) | common horizontal shift of the errors |"
          " minus the mean true displacement of the observed faces | offset error after the shift, median |")
    print("|---|---|---|---|---|")
    for name in ("demo_office", "AC20-FZK-Haus", "duplex", "large_office"):
        try:
            errors = observed_faces(f"{out}/{name}/run_as_built", f"{out}/{name}/dump")[1]
        except (OSError, ValueError, KeyError):
            print(f"| {name} | run failed | | | |")
            continue
        if not errors:
            print(f"| {name} | no element observed | | | |")
            continue
        dx, dy = common_shift(errors)
        tight = [f for f in errors if f["sigma"] <= 0.005]
        raw = [abs(f["error"]) for f in tight]
        left = [abs(f["error"] - f["normal"][0] * dx - f["normal"][1] * dy) for f in tight]
        mx = -sum(f["moved"][0] for f in errors) / len(errors)
        my = -sum(f["moved"][1] for f in errors) / len(errors)
        if not raw:
            print(f"| {name} | no offset with sigma <= 5 mm | | | |")
            continue
        print(f"| {name} | {1000 * statistics.median(raw):.1f} mm ({len(raw)}) | ({1000 * dx:.1f}, {1000 * dy:.1f}) mm"
              f" over {len(errors)} elements | ({1000 * mx:.1f}, {1000 * my:.1f}) mm |"
              f" {1000 * statistics.median(left):.1f} mm |")


if __name__ == "__main__":
    main()
