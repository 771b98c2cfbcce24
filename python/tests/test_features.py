# SPDX-License-Identifier: BSD-3-Clause
"""FPFH against Open3D's features of the bunny (the C++ tests' golden file), SAC-IA against a known
motion, segment_frame against `plumb segment`'s labels."""

import pathlib

import numpy as np
import pytest

import plumb

GOLDEN = pathlib.Path(__file__).resolve().parents[2] / "tests" / "features" / "golden" / "bunny_open3d_fpfh.txt"


def read_golden():
    """(normals (N, 3), [(radius, max_nn, features (N, 33))]) of the golden file."""
    lines = [line.split() for line in GOLDEN.read_text().splitlines() if line and not line.startswith("#")]
    n = int(lines[0][1])
    normals = np.array(lines[2:2 + n], dtype=np.float32)
    configs, pos = [], 2 + n
    while pos < len(lines):
        _, _, radius, max_nn = lines[pos]
        configs.append((float(radius), int(max_nn), np.array(lines[pos + 1:pos + 1 + n], dtype=np.float32)))
        pos += 1 + n
    return normals, configs


def test_compute_fpfh_equals_open3d_on_the_bunny(data_path):
    cloud = plumb.read_pcd(data_path("cloud3d/pcl_test/bunny.pcd"))
    normals, configs = read_golden()
    cloud.normals = normals
    assert len(configs) == 2
    for radius, max_nn, expected in configs:
        r = plumb.compute_fpfh(cloud, radius=radius, max_neighbors=max_nn)
        assert r.features.shape == (len(cloud), 33) and r.features.dtype == np.float32
        assert r.num_invalid == 0
        np.testing.assert_array_equal(r.indices, np.arange(len(cloud)))
        np.testing.assert_allclose(r.features, expected, rtol=0, atol=1e-3)
    some = np.array([5, 100, 7])
    subset = plumb.compute_fpfh(cloud, indices=some, radius=configs[0][0], max_neighbors=configs[0][1])
    np.testing.assert_array_equal(subset.indices, some)
    np.testing.assert_allclose(subset.features, configs[0][2][some], atol=1e-3)


def rotation_z(angle):
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def test_align_sac_ia_recovers_a_known_motion(data_path):
    room = plumb.read_pcd(data_path("cloud3d/pcl_room_scans/room_scan1.pcd"), drop_non_finite=True)
    target = plumb.voxel_grid(room, leaf_size=0.1).cloud
    target.normals = plumb.estimate_normals(target.points, k=15).normals
    T = np.eye(4)
    T[:3, :3] = rotation_z(0.4)
    T[:3, 3] = [0.8, -0.5, 0.1]
    # source = T^-1 target, so T_target_source = T.
    src_points = (target.points.astype(np.float64) - T[:3, 3]) @ T[:3, :3]
    source = plumb.PointCloud(src_points.astype(np.float32), normals=(target.normals @ T[:3, :3]).astype(np.float32))
    f_target = plumb.compute_fpfh(target, radius=0.5).features
    f_source = plumb.compute_fpfh(source, radius=0.5).features
    r = plumb.align_sac_ia(source, f_source, target, f_target, huber_threshold=0.1, max_correspondence_distance=0.3)
    assert r.status in (plumb.Status.ok, plumb.Status.not_converged)
    assert r.overlap > 0.8
    assert np.linalg.norm(r.T_target_source[:3, 3] - T[:3, 3]) < 0.1
    dR = r.T_target_source[:3, :3].T @ T[:3, :3]
    assert np.degrees(np.arccos(np.clip((np.trace(dR) - 1) / 2, -1, 1))) < 3.0
    with pytest.raises(ValueError, match="source_features"):
        plumb.align_sac_ia(source, f_source[:, :32], target, f_target)


def test_segment_frame_equals_plumb_segment(sim_run, run_cli, tmp_path):
    frame_path = sim_run[0] / "frames" / "000010.pcd"
    done = run_cli("segment", frame_path, "--labels-out", tmp_path / "labels.txt")
    assert done.returncode == 0, done.stderr
    expected = np.loadtxt(tmp_path / "labels.txt", dtype=np.int32)
    r = plumb.segment_frame(plumb.read_pcd(frame_path))
    assert r.status == plumb.Status.ok
    np.testing.assert_array_equal(r.labels, expected)
    assert r.num_ground == np.count_nonzero(expected == plumb.SEGMENT_GROUND)
    assert r.num_vertical == np.count_nonzero(expected == plumb.SEGMENT_VERTICAL)
    assert np.all(r.labels[r.ground_inliers] == plumb.SEGMENT_GROUND)
    # The ground lies 0.55 m below the LiDAR (meta.json T_base_lidar).
    ground_z = plumb.read_pcd(frame_path).points[r.labels == plumb.SEGMENT_GROUND, 2]
    assert abs(np.median(ground_z) + 0.55) < 0.02
