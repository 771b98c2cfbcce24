# SPDX-License-Identifier: BSD-3-Clause
"""Shared fixtures: the shared test data ($PLUMB_DATA_DIR) and the `plumb` CLI ($PLUMB_CLI), both set
by ctest; a test whose data or CLI is missing is skipped, never passed."""

import os
import pathlib
import subprocess

import pytest


@pytest.fixture(scope="session")
def data_path():
    default = pathlib.Path(__file__).resolve().parents[3] / "shared" / "data"
    root = pathlib.Path(os.environ.get("PLUMB_DATA_DIR", default))

    def path(rel):
        p = root / rel
        if not p.is_file():
            pytest.skip(f"test data not found: {p} (set PLUMB_DATA_DIR)")
        return p

    return path


@pytest.fixture(scope="session")
def run_cli():
    cli = os.environ.get("PLUMB_CLI", "")
    if not cli or not os.access(cli, os.X_OK):
        pytest.skip("the plumb CLI is not built (PLUMB_CLI)")

    def run(*args):
        return subprocess.run([cli, *map(str, args)], capture_output=True, text=True, check=False)

    return run


@pytest.fixture(scope="session")
def demo_model():
    """The demo office building shipped with the examples (IFC4)."""
    return pathlib.Path(__file__).resolve().parents[2] / "examples" / "data" / "demo_office.ifc"


@pytest.fixture(scope="session")
def sim_run(tmp_path_factory, run_cli, demo_model):
    """A short simulated drive through the demo office (`plumb simulate`, 4 m, about 100 frames) and
    `plumb run` over it: (dump directory, run output directory)."""
    root = tmp_path_factory.mktemp("sim")
    dump, out = root / "dump", root / "run"
    done = run_cli("simulate", demo_model, "-o", dump, "--length", 4, "--threads", 2)
    assert done.returncode == 0, done.stderr
    done = run_cli("run", dump, "--bim", demo_model, "-o", out, "--json")
    assert done.returncode == 0, done.stderr
    return dump, out
