# SPDX-License-Identifier: BSD-3-Clause
"""bench/python_overhead.py runs against the build's C++ benchmarks and reports both calls."""

import os
import pathlib
import re
import subprocess
import sys

import pytest

import plumb

ROOT = pathlib.Path(__file__).resolve().parents[2]


def test_overhead_script_reports_both_calls(data_path):
    data_path("cloud3d/pcl_room_scans/room_scan1.pcd")
    build = pathlib.Path(plumb.__file__).resolve().parents[2]
    if not (build / "bench" / "plumb_filters_bench").is_file() or not (build / "bench" / "plumb_search_bench").is_file():
        pytest.skip("the benchmarks are not built (PLUMB_BUILD_BENCH)")
    done = subprocess.run(
        [sys.executable, str(ROOT / "bench" / "python_overhead.py"), "--build", str(build), "--repetitions", "1"],
        capture_output=True, text=True, check=False, env=dict(os.environ))
    assert done.returncode == 0, done.stderr
    assert "room_scan1: 112586 points" in done.stdout
    for name in ("voxel_grid/plumb/room_scan1", "kdtree_knn10/plumb/room_scan1"):
        row = next(line for line in done.stdout.splitlines() if line.endswith(name))
        python_ms, cpp_ms, ratio = map(float, re.split(r"\s+", row)[1:4])
        assert python_ms > 0 and cpp_ms > 0 and ratio == pytest.approx(python_ms / cpp_ms, rel=0.02)
