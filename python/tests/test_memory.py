# SPDX-License-Identifier: BSD-3-Clause
"""Memory of the long-running commands: `plumb run` and `plumb lio` report their peak resident
memory in report.json, checked against what the kernel reports for the finished process; it
stays flat with the length of the run (frames and the IMU log are
streamed from the dump, the maps are bounded): a run twice as long needs no more than 1.2x the
memory."""

import json
import os
import pathlib
import shutil
import subprocess
import tempfile

import pytest


def run_measured(cli, *args):
    """Run `plumb ARGS`; return (exit status, stderr, the child's peak RSS in MiB as the kernel
    reports it). GNU time starts the child: Linux carries a process's peak RSS across exec, so a
    child forked from this (large) Python process would start at its figure; one forked from time
    starts at time's few pages."""
    time = shutil.which("time", path="/usr/bin:/bin")
    assert time, "GNU time is needed (apt install time; scripts/setup.sh installs it)"
    with tempfile.TemporaryDirectory() as tmp:
        kib = pathlib.Path(tmp) / "maxrss_kib"
        child = subprocess.run([time, "-f", "%M", "-o", kib, cli, *map(str, args)], stdout=subprocess.DEVNULL,
                               stderr=subprocess.PIPE, text=True, check=False)
        return child.returncode, child.stderr, float(kib.read_text().split()[-1]) / 1024.0


@pytest.fixture(scope="module")
def cli(run_cli):
    return os.environ["PLUMB_CLI"]  # run_cli skipped the module when it is not built


def peak_of(cli, tmp_path, command, dump, *options):
    out = tmp_path / f"{command}_{dump.name}"
    code, err, kernel_mib = run_measured(cli, command, dump, "-o", out, *options)
    assert code == 0, err
    reported = json.loads((out / "report.json").read_text())["peak_rss_mib"]
    # The report is written at the end of the run: the kernel's figure for the whole process may
    # only add what writing it took.
    assert 0.9 * kernel_mib <= reported <= kernel_mib, (reported, kernel_mib)
    return reported


def simulate(cli, tmp_path, name, *options):
    dump = tmp_path / name
    code, err, _ = run_measured(cli, "simulate", *options, "-o", dump, "--seed", 2)
    assert code == 0, err
    return dump


@pytest.fixture(scope="module")
def office_drives(cli, tmp_path_factory, demo_model):
    """The demo office driven 10 m and 20 m (VLP-16): (short dump, long dump)."""
    tmp = tmp_path_factory.mktemp("office_drives")
    return tuple(simulate(cli, tmp, f"office_{length}m", demo_model, "--lidar", "vlp16", "--length", length)
                 for length in (10, 20))


def with_dense_imu(dump, factor):
    """A copy of `dump` whose imu.csv has `factor` times the samples (linear interpolation between
    the recorded ones; 200 Hz becomes 200 * factor Hz): what a fast IMU logs over the same drive.
    Written line by line: this process's own memory must stay small, since the kernel's peak figure
    for a child starts from that of the process it was forked from."""
    dense = dump.parent / f"{dump.name}_imu_x{factor}"
    shutil.copytree(dump, dense)
    with open(dump / "imu.csv") as src, open(dense / "imu.csv", "w") as out:
        out.write(src.readline())
        last = None
        for line in src:
            if not line.strip() or line.startswith("#"):
                continue
            row = [float(x) for x in line.split(",")]
            if last is not None:
                for j in range(factor):
                    u = j / factor
                    out.write(",".join(repr(x + u * (y - x)) for x, y in zip(last, row)) + "\n")
            last = row
        out.write(",".join(map(repr, last)) + "\n")
    return dense


def test_run_memory_is_reported_and_flat_in_the_run_length(cli, tmp_path, demo_model, office_drives):
    short, long = office_drives
    options = ("--bim", demo_model, "--gt-start", "--threads", 1)
    assert peak_of(cli, tmp_path, "run", long, *options) <= 1.2 * peak_of(cli, tmp_path, "run", short, *options)


def test_lio_memory_is_reported_and_flat_in_the_run_length(cli, tmp_path, office_drives):
    # A 2 kHz IMU: a log that holds the whole run in memory would make the long run's figure grow
    # by about 10 MiB (measured: 1.5x); streamed, it does not. The map is bounded by --map-window,
    # so what the run keeps per frame is all that may grow.
    short, long = (with_dense_imu(d, 10) for d in office_drives)
    options = ("--mode", "hybrid", "--threads", 1, "--map-window", 100)
    assert peak_of(cli, tmp_path, "lio", long, *options) <= 1.2 * peak_of(cli, tmp_path, "lio", short, *options)


def test_lio_reports_its_peak_memory_on_a_site_run(cli, tmp_path, data_path):
    model = data_path("ifc/buildings/AC20-FZK-Haus.ifc")
    dump = simulate(cli, tmp_path, "site", model, "--scenario", "site", "--length", 10)
    assert peak_of(cli, tmp_path, "lio", dump, "--mode", "hybrid", "--threads", 1) > 1.0
