# SPDX-License-Identifier: BSD-3-Clause
"""examples/python/quickstart.py runs end to end and writes a real PNG plot."""

import os
import pathlib
import struct
import subprocess
import sys

import pytest

QUICKSTART = pathlib.Path(__file__).resolve().parents[2] / "examples" / "python" / "quickstart.py"


def png_size(path):
    """(width, height) from a PNG's signature and IHDR chunk; fails on anything else."""
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n", "not a PNG signature"
    length, kind = struct.unpack(">I4s", data[8:16])
    assert kind == b"IHDR" and length == 13
    assert data[-8:-4] == b"IEND", "truncated PNG"
    return struct.unpack(">II", data[16:24])


@pytest.mark.parametrize("source", ["dump", "simulate"])
def test_quickstart_writes_a_png(sim_run, run_cli, tmp_path, source):
    out = tmp_path / "trajectory.png"
    args = [sys.executable, str(QUICKSTART), str(out)]
    args += ["--dump", str(sim_run[0])] if source == "dump" else ["--plumb", os.environ["PLUMB_CLI"], "--length", "3"]
    done = subprocess.run(args, capture_output=True, text=True, check=False)
    assert done.returncode == 0, done.stderr
    assert "horizontal error vs truth" in done.stdout
    width, height = png_size(out)
    assert (width, height) == (960, 600)
    assert out.stat().st_size > 20000
