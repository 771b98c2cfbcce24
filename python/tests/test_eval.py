# SPDX-License-Identifier: BSD-3-Clause
"""ape, rpe, align_umeyama, associate and compute_stats against evo's published KITTI 00 numbers,
the plumb CLI, numpy and known similarities."""

import json

import numpy as np
import pytest

import plumb

STAT_NAMES = ("rmse", "mean", "median", "std", "min", "max", "sse")


@pytest.fixture(scope="module")
def kitti00(data_path):
    est_path = data_path("trajectories/kitti00/KITTI_00_ORB.txt")
    ref_path = data_path("trajectories/kitti00/KITTI_00_gt.txt")
    # evo does not re-orthonormalize the rotations, and neither does the CLI by default.
    return est_path, ref_path, plumb.read_kitti(est_path, orthonormalize=False), \
        plumb.read_kitti(ref_path, orthonormalize=False)


def test_ape_on_kitti00_equals_evo(kitti00, data_path):
    _, _, est, ref = kitti00
    evo = json.loads(data_path("trajectories/kitti00/evo_reference/orb_ape_stats.json").read_text())
    ape = plumb.ape(est, ref)  # SE(3) Umeyama alignment by default
    assert ape.status == plumb.Status.ok
    assert ape.translation.stats.count == 4541 and ape.translation.values.shape == (4541,)
    assert ape.translation.stats.rmse == pytest.approx(1.3034497, abs=1e-7)
    for name in STAT_NAMES:
        assert getattr(ape.translation.stats, name) == pytest.approx(evo[name], rel=1e-9, abs=1e-6), name
    assert ape.alignment.scale == 1.0 and ape.alignment.T_ref_est.shape == (4, 4)


def test_rpe_on_kitti00_equals_evo(kitti00, data_path):
    _, _, est, ref = kitti00
    evo = json.loads(data_path("trajectories/kitti00/evo_reference/orb_rpe_stats.json").read_text())
    rpe = plumb.rpe(est, ref, delta=10.0, unit=plumb.DeltaUnit.meters)
    assert rpe.status == plumb.Status.ok
    assert rpe.pairs.shape == (rpe.translation.stats.count, 2)
    for name in STAT_NAMES:
        assert getattr(rpe.translation.stats, name) == pytest.approx(evo[name], rel=1e-9, abs=1e-6), name


def test_ape_and_rpe_equal_the_cli(kitti00, run_cli):
    est_path, ref_path, est, ref = kitti00
    cli = run_cli("eval", est_path, ref_path, "--format", "kitti", "--json")
    assert cli.returncode == 0, cli.stderr
    report = json.loads(cli.stdout)
    ape = plumb.ape(est, ref)
    rpe = plumb.rpe(est, ref)  # the CLI's default: 1 frame, along the estimate, not aligned
    for name in STAT_NAMES:
        assert getattr(ape.translation.stats, name) == pytest.approx(report["ape"][name], rel=1e-12), name
        assert getattr(ape.rotation_deg.stats, name) == pytest.approx(report["ape_rotation_deg"][name], rel=1e-12)
        assert getattr(rpe.translation.stats, name) == pytest.approx(report["rpe"][name], rel=1e-12), name
    np.testing.assert_allclose(ape.alignment.T_ref_est[:3, :3], report["alignment"]["rotation"], rtol=0, atol=1e-14)
    np.testing.assert_allclose(ape.alignment.T_ref_est[:3, 3], report["alignment"]["translation"], rtol=0, atol=1e-12)


def random_rotation(rng):
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q *= np.sign(np.diag(r))
    return q * np.linalg.det(q)


def test_align_umeyama_recovers_a_known_similarity():
    rng = np.random.default_rng(8)
    source = rng.normal(size=(50, 3))
    R, t, s = random_rotation(rng), np.array([1.0, -2.0, 0.5]), 1.7
    target = s * source @ R.T + t
    sim3 = plumb.align_umeyama(source, target, with_scale=True)
    assert sim3.status == plumb.Status.ok
    assert sim3.scale == pytest.approx(s, rel=1e-12) and sim3.rmse < 1e-12
    np.testing.assert_allclose(sim3.T_ref_est[:3, :3], R, atol=1e-12)
    np.testing.assert_allclose(sim3.T_ref_est[:3, 3], t, atol=1e-12)
    se3 = plumb.align_umeyama(source, target)
    assert se3.scale == 1.0 and se3.rmse > 0.1
    collinear = plumb.align_umeyama(np.outer(np.arange(5.0), [1, 0, 0]), np.outer(np.arange(5.0), [0, 1, 0]))
    assert collinear.status == plumb.Status.degenerate
    with pytest.raises(plumb.Error):
        plumb.align_umeyama(source, target[:10])


def test_associate_and_align_trajectory():
    poses = np.tile(np.eye(4), (20, 1, 1))
    poses[:, :3, 3] = np.column_stack([np.arange(20.0), np.sin(np.arange(20.0)), np.zeros(20)])
    ref = plumb.Trajectory(poses, stamps=np.arange(20) * 0.1)
    est = plumb.Trajectory(poses[::2], stamps=np.arange(10) * 0.2 + 0.004)
    pairs = plumb.associate(est, ref)
    assert pairs.by_stamp and len(pairs.estimate) == 10
    np.testing.assert_array_equal(pairs.reference_indices, np.arange(0, 20, 2))
    np.testing.assert_array_equal(pairs.estimate_indices, np.arange(10))
    with pytest.raises(plumb.Error, match=r"^associate:"):
        plumb.associate(est, ref, max_time_difference=0.001)
    moved = poses.copy()
    moved[:, :3, 3] += [5.0, 0.0, 1.0]
    aligned = plumb.align_trajectory(plumb.Trajectory(moved), plumb.Trajectory(poses))
    np.testing.assert_allclose(aligned.aligned.poses, poses, atol=1e-9)
    np.testing.assert_allclose(aligned.transform.T_ref_est[:3, 3], [-5.0, 0.0, -1.0], atol=1e-9)


def test_compute_stats_matches_numpy():
    errors = np.random.default_rng(9).random(101)
    stats = plumb.compute_stats(errors)
    assert stats.count == 101
    assert stats.rmse == pytest.approx(np.sqrt(np.mean(errors ** 2)), rel=1e-14)
    assert stats.mean == pytest.approx(errors.mean(), rel=1e-14)
    assert stats.median == pytest.approx(np.median(errors), rel=1e-14)
    assert stats.std == pytest.approx(errors.std(), rel=1e-12)
    assert (stats.min, stats.max) == (errors.min(), errors.max())
    with pytest.raises(plumb.Error):
        plumb.compute_stats(np.array([]))
