# SPDX-License-Identifier: BSD-3-Clause
"""Memory of the long-running commands: `plumb run` and `plumb lio` report their peak resident
memory in report.json, checked against what the kernel reports for the finished process; that of
`plumb run` stays flat with the length of the run (frames are streamed from the dump, the BIM
odometry keeps no growing map): a run twice as long needs no more than 1.2x the memory."""

import json
import os
import subprocess

import pytest


def run_measured(cli, *args):
    """Run `plumb ARGS`; return (exit status, stderr, the child's peak RSS in MiB from wait4)."""
    with subprocess.Popen([cli, *map(str, args)], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                          text=True) as child:
        err = child.stderr.read()
        _, status, usage = os.wait4(child.pid, 0)
        child.returncode = os.waitstatus_to_exitcode(status)
    return child.returncode, err, usage.ru_maxrss / 1024.0  # Linux: KiB


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


def test_run_memory_is_reported_and_flat_in_the_run_length(cli, tmp_path, demo_model):
    short = simulate(cli, tmp_path, "office_short", demo_model, "--lidar", "vlp16", "--length", 10)
    long = simulate(cli, tmp_path, "office_long", demo_model, "--lidar", "vlp16", "--length", 20)
    options = ("--bim", demo_model, "--gt-start", "--threads", 1)
    assert peak_of(cli, tmp_path, "run", long, *options) <= 1.2 * peak_of(cli, tmp_path, "run", short, *options)


def test_lio_reports_its_peak_memory(cli, tmp_path, data_path):
    model = data_path("ifc/buildings/AC20-FZK-Haus.ifc")
    dump = simulate(cli, tmp_path, "site", model, "--scenario", "site", "--length", 10)
    assert peak_of(cli, tmp_path, "lio", dump, "--mode", "hybrid", "--threads", 1) > 1.0
