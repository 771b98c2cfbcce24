# SPDX-License-Identifier: BSD-3-Clause
"""Planar scans: cloud_to_scan against a brute-force numpy binning, PLICP against a known motion in
a rectangular room ray-cast here, the odometry/laser calibration against Censi's published result
(AndreaCensi/calibration reference output, the C++ tests' reference) and `plumb calibrate`."""

import json

import numpy as np
import pytest

import plumb


def test_cloud_to_scan_equals_brute_force(sim_run):
    points = plumb.FrameDump(sim_run[0]).frame(10).points
    inc = np.pi / 360
    r = plumb.cloud_to_scan(points, min_height=-0.1, max_height=0.1, angle_increment=inc, range_min=0.5)
    p = points.astype(np.float64)
    keep = (p[:, 2] >= -0.1) & (p[:, 2] <= 0.1)
    assert r.num_in_band == np.count_nonzero(keep)
    rng = np.hypot(p[:, 0], p[:, 1])
    keep &= rng >= 0.5
    bins = np.minimum(((np.arctan2(p[:, 1], p[:, 0]) + np.pi) / inc).astype(np.int64), 719)
    expected = np.full(720, np.inf, np.float32)
    nearest = np.full(720, -1)
    for i in np.flatnonzero(keep):
        if nearest[bins[i]] < 0 or rng[i] < rng[nearest[bins[i]]]:
            nearest[bins[i]] = i
            expected[bins[i]] = rng[i]
    assert len(r.scan) == 720
    np.testing.assert_allclose(r.scan.ranges, expected, rtol=1e-6)
    np.testing.assert_array_equal(r.beam_indices, np.flatnonzero(nearest >= 0))
    np.testing.assert_array_equal(r.source_indices, nearest[nearest >= 0])
    np.testing.assert_allclose(r.points, p[nearest[nearest >= 0], :2], atol=1e-12)


def room_scan(pose, beams=720):
    """Ranges from pose (x, y, theta) to the walls of the room [-4, 6] x [-3, 5], regular beams."""
    x, y, th = pose
    angles = -np.pi + np.arange(beams) * (2 * np.pi / beams)
    d = np.stack([np.cos(angles + th), np.sin(angles + th)], axis=1)
    with np.errstate(divide="ignore"):
        tx = np.where(d[:, 0] > 0, (6 - x) / d[:, 0], (-4 - x) / d[:, 0])
        ty = np.where(d[:, 1] > 0, (5 - y) / d[:, 1], (-3 - y) / d[:, 1])
    ranges = np.minimum(np.abs(tx), np.abs(ty)).astype(np.float32)
    return plumb.LaserScan(ranges, angle_min=-np.pi, angle_increment=2 * np.pi / beams, range_max=30.0)


def test_plicp_recovers_a_known_motion():
    reference = room_scan((0.0, 0.0, 0.0))
    truth = np.array([0.2, -0.1, 0.05])
    current = room_scan(truth)
    r = plumb.plicp(current, reference)
    assert r.status == plumb.Status.ok and r.converged
    np.testing.assert_allclose(r.T_ref_cur, truth, atol=1e-3)
    assert r.num_points == current.num_valid() == 720
    one = plumb.plicp(current, reference, max_iterations=1)
    assert one.iterations == 1 and not one.converged
    from_truth = plumb.plicp(current, reference, truth)
    assert from_truth.iterations < r.iterations
    np.testing.assert_allclose(from_truth.T_ref_cur, truth, atol=1e-3)


@pytest.mark.parametrize("name", ["l90", "l90_0", "l90_1", "l90_2"])
def test_calibration_within_one_sigma_of_censi(data_path, name):
    tuples = plumb.read_calib_tuples(data_path(f"laser2d/calibration_censi/{name}.tuple"))
    ref = json.loads(data_path(f"laser2d/calibration_censi/{name}_results.json").read_text())
    est = plumb.calibrate_odometry_laser(tuples)
    assert est.status == plumb.Status.ok and est.num_tuples == len(tuples)
    expected = np.array([ref["l_diam"] / 2, ref["r_diam"] / 2, ref["axle"], ref["l_x"], ref["l_y"], ref["l_theta"]])
    sigma = np.sqrt(np.diag(np.array(ref["covariance"])))
    assert np.all(np.abs(est.params - expected) <= sigma)
    np.testing.assert_allclose(np.sqrt(np.diag(est.covariance)), sigma, rtol=0.1)


def test_calibration_equals_plumb_calibrate(data_path, run_cli):
    path = data_path("laser2d/calibration_censi/l90.tuple")
    done = run_cli("calibrate", path, "--json")
    assert done.returncode == 0, done.stderr
    cli = json.loads(done.stdout)
    est = plumb.calibrate_odometry_laser(plumb.read_calib_tuples(path))
    got = dict(zip(["l_diam", "r_diam", "axle", "l_x", "l_y", "l_theta"], est.params * [2, 2, 1, 1, 1, 1]))
    for key, value in got.items():
        assert value == pytest.approx(cli[key], rel=1e-12, abs=1e-15), key
    np.testing.assert_allclose(est.covariance, cli["covariance"], rtol=1e-12)
