# SPDX-License-Identifier: BSD-3-Clause
"""File formats, each against an independent reader or writer written with numpy here, and the
C++ error messages (the same text the plumb CLI prints)."""

import pathlib

import numpy as np
import pytest

import plumb
from pcd_numpy import pcd_header_and_data


def test_read_pcd_binary_matches_numpy(data_path):
    path = data_path("cloud3d/hdl32_pair/251370668.pcd")
    header, data = pcd_header_and_data(path)
    assert header["FIELDS"] == ["x", "y", "z", "intensity"] and header["DATA"] == ["binary"]
    n = int(header["POINTS"][0])
    ref = np.frombuffer(data[: n * 16], dtype="<f4").reshape(n, 4)
    cloud = plumb.read_pcd(path)
    assert cloud.points.shape == (n, 3)
    np.testing.assert_array_equal(cloud.points, ref[:, :3])
    np.testing.assert_array_equal(cloud.intensities, ref[:, 3])


def test_read_pcd_ascii_with_normals_matches_numpy(data_path):
    path = data_path("cloud3d/pcl_test/bun0.pcd")
    header, data = pcd_header_and_data(path)
    ref = np.loadtxt(data.decode().splitlines(), dtype=np.float32)
    cloud = plumb.read_pcd(str(path))
    np.testing.assert_array_equal(cloud.points, ref[:, 0:3])
    np.testing.assert_array_equal(cloud.normals, ref[:, 3:6])
    assert not cloud.has_intensities()


@pytest.mark.parametrize("encoding", [plumb.PcdEncoding.ascii, plumb.PcdEncoding.binary,
                                      plumb.PcdEncoding.binary_compressed])
def test_write_pcd_round_trips_every_field(tmp_path, encoding):
    rng = np.random.default_rng(1)
    cloud = plumb.PointCloud(rng.normal(size=(50, 3)).astype(np.float32), intensities=rng.random(50),
                             rings=rng.integers(0, 32, 50), times=rng.random(50), labels=rng.integers(-5, 5, 50))
    path = tmp_path / "cloud.pcd"
    plumb.write_pcd(path, cloud, encoding=encoding)
    back = plumb.read_pcd(path)
    for field in ("points", "intensities", "rings", "times", "labels"):
        np.testing.assert_array_equal(getattr(back, field), getattr(cloud, field))


def test_write_pcd_binary_is_readable_by_numpy(tmp_path, data_path):
    # binary_compressed input (LZF) written back as plain binary and parsed here.
    cloud = plumb.read_pcd(data_path("cloud3d/pcl_room_scans/room_scan1.pcd"))
    header, _ = pcd_header_and_data(data_path("cloud3d/pcl_room_scans/room_scan1.pcd"))
    assert len(cloud) == int(header["POINTS"][0])
    path = tmp_path / "room.pcd"
    plumb.write_pcd(path, cloud.points)
    header, data = pcd_header_and_data(path)
    assert header["FIELDS"] == ["x", "y", "z"] and header["DATA"] == ["binary"]
    np.testing.assert_array_equal(np.frombuffer(data, dtype="<f4").reshape(-1, 3), cloud.points)


def test_read_ply_matches_a_hand_written_file(tmp_path):
    text = """ply
format ascii 1.0
element vertex 3
property float x
property float y
property float z
property uchar red
property float intensity
element face 1
property list uchar int vertex_indices
end_header
1 2 3 255 0.5
-1.5 0 2.25 0 1
4 5 6 7 0.25
3 0 1 2
"""
    path = tmp_path / "hand.ply"
    path.write_text(text)
    cloud = plumb.read_ply(path)
    np.testing.assert_array_equal(cloud.points, [[1, 2, 3], [-1.5, 0, 2.25], [4, 5, 6]])
    np.testing.assert_array_equal(cloud.intensities, [0.5, 1.0, 0.25])


def test_write_ply_binary_is_readable_by_numpy(tmp_path):
    rng = np.random.default_rng(2)
    pts = rng.normal(size=(20, 3)).astype(np.float32)
    labels = rng.integers(0, 100, 20).astype(np.int32)
    path = tmp_path / "out.ply"
    plumb.write_ply(path, plumb.PointCloud(pts, labels=labels))
    raw = path.read_bytes()
    header, data = raw.split(b"end_header\n", 1)
    assert b"format binary_little_endian 1.0" in header and b"element vertex 20" in header
    rec = np.frombuffer(data, dtype=[("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("label", "<i4")])
    np.testing.assert_array_equal(np.stack([rec["x"], rec["y"], rec["z"]], axis=1), pts)
    np.testing.assert_array_equal(rec["label"], labels)
    back = plumb.read_ply(path)
    np.testing.assert_array_equal(back.points, pts)


def test_kitti_bin_against_numpy(tmp_path):
    rng = np.random.default_rng(3)
    records = rng.normal(size=(100, 4)).astype("<f4")
    path = tmp_path / "000000.bin"
    records.tofile(path)
    cloud = plumb.read_kitti_bin(path)
    np.testing.assert_array_equal(cloud.points, records[:, :3])
    np.testing.assert_array_equal(cloud.intensities, records[:, 3])
    out = tmp_path / "out.bin"
    plumb.write_kitti_bin(out, records[:, :3])
    written = np.fromfile(out, dtype="<f4").reshape(-1, 4)
    np.testing.assert_array_equal(written[:, :3], records[:, :3])
    np.testing.assert_array_equal(written[:, 3], 0.0)


def quaternion_matrix(qx, qy, qz, qw):
    q = np.array([qx, qy, qz, qw]) / np.linalg.norm([qx, qy, qz, qw])
    x, y, z, w = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def test_tum_read_and_write_against_numpy(tmp_path):
    rows = [[0.0, 1.0, 2.0, 3.0, 0.0, 0.0, 0.0, 1.0],
            [0.5, 1.5, 2.5, 3.5, 0.0, 0.0, np.sin(0.25), np.cos(0.25)],
            [1.0, -1.0, 0.0, 0.25, 0.1, 0.2, 0.3, 0.9273618495495703]]
    path = tmp_path / "traj.tum"
    path.write_text("# stamp tx ty tz qx qy qz qw\n" + "".join(" ".join(repr(v) for v in r) + "\n" for r in rows))
    traj = plumb.read_tum(path)
    np.testing.assert_array_equal(traj.stamps, [r[0] for r in rows])
    for pose, r in zip(traj.poses, rows):
        np.testing.assert_array_equal(pose[:3, 3], r[1:4])
        np.testing.assert_allclose(pose[:3, :3], quaternion_matrix(*r[4:8]), atol=1e-15)
        np.testing.assert_array_equal(pose[3], [0, 0, 0, 1])
    out = tmp_path / "out.tum"
    plumb.write_tum(traj, out)
    written = np.loadtxt(out)
    np.testing.assert_array_equal(written[:, :4], np.array(rows)[:, :4])
    for w, r in zip(written, rows):
        np.testing.assert_allclose(quaternion_matrix(*w[4:8]), quaternion_matrix(*r[4:8]), atol=1e-15)


def test_read_kitti_as_printed_matches_numpy(data_path):
    path = data_path("trajectories/kitti00/KITTI_00_gt.txt")
    traj = plumb.read_kitti(path, orthonormalize=False)
    ref = np.loadtxt(path).reshape(-1, 3, 4)
    assert not traj.has_stamps()
    np.testing.assert_array_equal(traj.poses[:, :3, :], ref)
    timed = plumb.read_kitti(path, data_path("trajectories/kitti00/KITTI_00_gt_times.txt"))
    np.testing.assert_array_equal(timed.stamps, np.loadtxt(data_path("trajectories/kitti00/KITTI_00_gt_times.txt")))


def test_errors_carry_the_cpp_message_the_cli_prints(tmp_path, data_path, run_cli):
    missing = tmp_path / "missing.txt"
    cli = run_cli("eval", missing, data_path("trajectories/kitti00/KITTI_00_gt.txt"), "--format", "tum")
    assert cli.returncode != 0
    prefix = "plumb: error: "
    assert cli.stderr.startswith(prefix)
    with pytest.raises(plumb.Error) as info:
        plumb.read_tum(missing)
    assert str(info.value) == cli.stderr[len(prefix):].strip()
    assert str(info.value) == f"{missing}: no such file"


def test_read_errors_name_the_file_and_line(tmp_path):
    path = tmp_path / "bad.tum"
    path.write_text("0 0 0 0 0 0 0 1\n1 0 0 nan 0 0 0 1\n")
    with pytest.raises(plumb.Error, match=rf"^{path}:2: "):
        plumb.read_tum(path)
    with pytest.raises(TypeError, match=r"read_tum\(\) got an unexpected keyword argument 'strict'"):
        plumb.read_tum(path, strict=True)


def test_write_errors(tmp_path):
    with pytest.raises(plumb.Error):
        plumb.write_tum(plumb.Trajectory(np.eye(4)[None]), tmp_path / "x.tum")
    with pytest.raises(ValueError, match=r"write_pcd: cloud: expected an \(N, 3\)"):
        plumb.write_pcd(tmp_path / "x.pcd", np.zeros((2, 4)))


def test_write_kitti_with_times_against_numpy(tmp_path):
    poses = np.tile(np.eye(4), (3, 1, 1))
    poses[:, :3, 3] = [[0.0, 0.0, 0.0], [1.25, -2.0, 0.5], [3.0, 1e-7, 2.0]]
    traj = plumb.Trajectory(poses, stamps=[0.0, 0.1, 0.25])
    plumb.write_kitti(traj, tmp_path / "poses.txt", tmp_path / "times.txt")
    np.testing.assert_array_equal(np.loadtxt(tmp_path / "poses.txt").reshape(-1, 3, 4), poses[:, :3, :])
    np.testing.assert_array_equal(np.loadtxt(tmp_path / "times.txt"), [0.0, 0.1, 0.25])
    plumb.write_kitti(traj, tmp_path / "only.txt")
    assert not (tmp_path / "only_times.txt").exists()
    assert not plumb.read_kitti(tmp_path / "only.txt").has_stamps()
