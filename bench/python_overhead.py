#!/usr/bin/env python3
# SPDX-License-Identifier: BSD-3-Clause
"""Cost of calling plumb from Python: the same work timed through the Python module and by the C++
Google Benchmarks that already measure it, on room_scan1 (shared/data, SOURCES.md).

  voxel_grid   room_scan1 (every point, as read), 0.1 m leaf, centroid mode
               -> C++ voxel_grid/plumb/room_scan1 (plumb_filters_bench)
  KdTree.knn   k = 10 for 20000 queries, a strided subset of the finite points (as search_bench
               takes them), on a tree with leaf size 10 built outside the timing
               -> C++ kdtree_knn10/plumb/room_scan1 (plumb_search_bench)

Python: median wall time of --repetitions calls (time.perf_counter); C++: the median of as many
benchmark repetitions. Prints one line per call with the ratio Python / C++.

  python3 bench/python_overhead.py --build build/rel [--data shared/data] [--repetitions 15]
"""

import argparse
import json
import os
import pathlib
import statistics
import subprocess
import sys
import time

ROOM_SCAN = "cloud3d/pcl_room_scans/room_scan1.pcd"
NUM_QUERIES = 20000


def median_seconds(fn, repetitions):
    fn()  # warm-up: caches, lazy allocations
    times = []
    for _ in range(repetitions):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def cpp_median_seconds(binary, name, repetitions, data_dir):
    """Median real time [s] of one Google Benchmark over `repetitions` repetitions."""
    out = subprocess.run(
        [str(binary), f"--benchmark_filter=^{name}$", f"--benchmark_repetitions={repetitions}",
         "--benchmark_format=json"],
        check=True, capture_output=True, text=True, env={**os.environ, "PLUMB_DATA_DIR": str(data_dir)})
    scale = {"ns": 1e-9, "us": 1e-6, "ms": 1e-3, "s": 1.0}
    runs = [b["real_time"] * scale[b["time_unit"]] for b in json.loads(out.stdout)["benchmarks"]
            if b.get("run_type") == "iteration"]
    if not runs:
        raise RuntimeError(f"{binary}: {name} did not run")
    return statistics.median(runs)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--build", default="build/rel", help="build directory with python/ and bench/")
    parser.add_argument("--data", default=os.environ.get("PLUMB_DATA_DIR", "../shared/data"),
                        help="shared data directory (default $PLUMB_DATA_DIR)")
    parser.add_argument("--repetitions", type=int, default=15)
    args = parser.parse_args()
    build = pathlib.Path(args.build).resolve()
    data = pathlib.Path(args.data).resolve()
    sys.path.insert(0, str(build / "python"))
    import numpy as np
    import plumb

    cloud = plumb.read_pcd(data / ROOM_SCAN)
    points = cloud.points[np.all(np.isfinite(cloud.points), axis=1)]
    n = len(points)
    m = min(n, NUM_QUERIES)
    queries = points[np.arange(m) * n // m]
    tree = plumb.KdTree(points, leaf_size=10)

    rows = [
        ("voxel_grid", lambda: plumb.voxel_grid(cloud, leaf_size=0.1, mode=plumb.VoxelMode.centroid),
         build / "bench" / "plumb_filters_bench", "voxel_grid/plumb/room_scan1"),
        ("KdTree.knn", lambda: tree.knn(queries, 10), build / "bench" / "plumb_search_bench",
         "kdtree_knn10/plumb/room_scan1"),
    ]
    print(f"room_scan1: {len(cloud)} points ({n} finite), {m} kNN queries; median of {args.repetitions}")
    print(f"{'call':<12} {'Python [ms]':>12} {'C++ [ms]':>10} {'Python / C++':>13}   C++ benchmark")
    for call, fn, binary, name in rows:
        py = median_seconds(fn, args.repetitions)
        cpp = cpp_median_seconds(binary, name, args.repetitions, data)
        print(f"{call:<12} {py * 1e3:12.2f} {cpp * 1e3:10.2f} {py / cpp:13.3f}   {name}")


if __name__ == "__main__":
    main()
