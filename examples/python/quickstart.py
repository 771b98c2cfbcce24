#!/usr/bin/env python3
# SPDX-License-Identifier: BSD-3-Clause
"""plumb from Python: a building model, a LiDAR frame dump, the BIM-corrected odometry fed one frame
at a time, and a plot of the trajectory against the ground truth.

    PYTHONPATH=build/python python3 examples/python/quickstart.py trajectory.png
        [--model MODEL.ifc] [--dump DIR | --plumb PATH_TO_PLUMB_CLI] [--length METRES]

Without --dump the drive is simulated first with the plumb CLI (`plumb simulate MODEL -o DIR`).
"""

import argparse
import os
import pathlib
import shutil
import subprocess
import sys
import tempfile

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import plumb  # noqa: E402

DEMO_MODEL = pathlib.Path(__file__).resolve().parents[1] / "data" / "demo_office.ifc"


def simulate(cli, model, length, out_dir):
    """A drive through the model written as a frame dump by `plumb simulate`."""
    subprocess.run([cli, "simulate", str(model), "-o", str(out_dir), "--length", str(length)], check=True,
                   stdout=subprocess.DEVNULL)
    return out_dir


def bim_odometry(mesh, dump):
    """Localize the first frame in the building, then BimOdometry frame by frame: (stamps, T_world_base)."""
    bim_cloud = plumb.sample_bim_cloud(mesh, 0.05)  # the model's surfaces, every 5 cm, with normals
    T_base_lidar = dump.meta.T_base_lidar
    odom = plumb.OdometryInterpolator(dump.odometry())  # wheel odometry at any time
    odometry = None
    stamps, poses = [], []
    for stamp, frame in dump:
        frame = plumb.deskew_frame(frame, stamp, T_base_lidar, odom)  # undo the motion during the sweep
        if odometry is None:
            start = plumb.BimLocalizer(mesh, bim_cloud).localize(frame, T_base_lidar)
            if start.status != plumb.Status.ok:
                sys.exit(f"the first frame was not localized: {start.status}")
            odometry = plumb.BimOdometry(bim_cloud, start.T_world_base, T_base_lidar=T_base_lidar)
        result = odometry.process(frame, stamp, odom.at(stamp))
        stamps.append(stamp)
        poses.append(result.T_world_base)
    return np.array(stamps), np.array(poses)


def plot(mesh, poses, truth, path):
    """Floor plan (the model's walls cut at 1 m), the estimate and the truth, seen from above."""
    fig, ax = plt.subplots(figsize=(8, 5))
    walls = plumb.sample_surface(mesh, spacing=0.1, types=["IfcWall"]).points
    cut = walls[np.abs(walls[:, 2] - 1.0) < 0.05]
    ax.scatter(cut[:, 0], cut[:, 1], s=0.5, c="0.6", label="walls (BIM)")
    if truth is not None:
        ax.plot(truth[:, 0, 3], truth[:, 1, 3], "k--", lw=1.5, label="ground truth")
    ax.plot(poses[:, 0, 3], poses[:, 1, 3], "C0", lw=1.5, label="BIM-corrected odometry")
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.legend(loc="upper right")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("png", help="where to write the plot (PNG)")
    parser.add_argument("--model", default=str(DEMO_MODEL), help="building model, IFC (default: the demo office)")
    parser.add_argument("--dump", help="frame dump directory (default: simulate one with the plumb CLI)")
    parser.add_argument("--plumb", default=os.environ.get("PLUMB_CLI") or shutil.which("plumb"),
                        help="the plumb CLI, to simulate a drive (default: $PLUMB_CLI, else plumb on PATH)")
    parser.add_argument("--length", type=float, default=10.0, help="metres to simulate (default 10)")
    args = parser.parse_args()

    mesh = plumb.read_ifc(args.model)
    with tempfile.TemporaryDirectory() as tmp:
        if args.dump is None:
            if not args.plumb:
                sys.exit("give --dump DIR, or the plumb CLI (--plumb PATH) to simulate one")
            args.dump = simulate(args.plumb, args.model, args.length, pathlib.Path(tmp) / "dump")
        dump = plumb.FrameDump(args.dump)
        stamps, poses = bim_odometry(mesh, dump)
        truth = dump.ground_truth().poses if dump.has_ground_truth() else None
    plot(mesh, poses, truth, args.png)
    print(f"{len(stamps)} frames, {stamps[-1] - stamps[0]:.1f} s", end="")
    if truth is not None:
        err = np.linalg.norm(poses[:, :2, 3] - truth[:len(poses), :2, 3], axis=1)
        print(f", horizontal error vs truth: RMS {np.sqrt(np.mean(err ** 2)):.3f} m, max {err.max():.3f} m", end="")
    print(f"; plot: {args.png}")


if __name__ == "__main__":
    main()
