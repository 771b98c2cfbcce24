# SPDX-License-Identifier: BSD-3-Clause
"""plumb.__version__, plumb.Error, PointCloud and Trajectory: array conventions and validation."""

import pathlib
import platform
import re
import resource

import numpy as np
import pytest

import plumb


def test_version_is_the_project_version():
    cmake = (pathlib.Path(__file__).resolve().parents[2] / "CMakeLists.txt").read_text()
    project_version = re.search(r"project\(plumb VERSION (\d+\.\d+\.\d+)", cmake).group(1)
    assert plumb.__version__ == project_version
    assert plumb.version() == project_version


@pytest.mark.skipif(platform.libc_ver()[0] != "glibc", reason="keep_freed_memory() applies to glibc only")
def test_keep_freed_memory_serves_each_frame_from_the_last_ones_memory():
    assert plumb.keep_freed_memory()

    def frame(i):  # a frame's worth of buffers, ~1.2 MiB each, touched and freed
        a = np.ones(300_000 + 1000 * i, dtype=np.float32)
        b = np.full(310_000, 2.0, dtype=np.float32)
        return float(a[-1] + b[-1])

    frame(0)
    frame(1)
    before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
    for i in range(2, 42):
        frame(i)
    pages_per_frame = 2 * 300_000 * 4 // 4096
    assert resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before < 2 * pages_per_frame


def test_error_is_a_runtime_error():
    assert issubclass(plumb.Error, RuntimeError)


def test_point_cloud_fields_round_trip_with_their_dtypes():
    pts = np.arange(12, dtype=np.float64).reshape(4, 3) / 7.0
    cloud = plumb.PointCloud(pts, intensities=[0.5, 1.0, 1.5, 2.0], rings=np.array([0, 1, 2, 65535]),
                             labels=np.array([-1, 0, 7, 2**31 - 1]))
    assert len(cloud) == 4 and cloud.size() == 4
    assert cloud.points.dtype == np.float32 and cloud.points.shape == (4, 3)
    np.testing.assert_array_equal(cloud.points, pts.astype(np.float32))
    assert cloud.intensities.dtype == np.float32
    np.testing.assert_array_equal(cloud.intensities, [0.5, 1.0, 1.5, 2.0])
    assert cloud.rings.dtype == np.uint16 and cloud.rings.tolist() == [0, 1, 2, 65535]
    assert cloud.labels.dtype == np.int32 and cloud.labels.tolist() == [-1, 0, 7, 2**31 - 1]
    assert cloud.has_intensities() and cloud.has_rings() and cloud.has_labels()
    assert not cloud.has_normals() and cloud.normals.shape == (0, 3)
    assert not cloud.has_times() and cloud.times.shape == (0,)
    cloud.normals = np.tile([0.0, 0.0, 1.0], (4, 1))
    assert cloud.has_normals()
    cloud.normals = None
    assert not cloud.has_normals()
    picked = cloud.select([3, 1])
    np.testing.assert_array_equal(picked.points, pts[[3, 1]].astype(np.float32))
    assert picked.rings.tolist() == [65535, 1]


def test_fields_are_copies():
    cloud = plumb.PointCloud(np.zeros((2, 3), np.float32))
    cloud.points[0, 0] = 5.0
    assert cloud.points[0, 0] == 0.0


@pytest.mark.parametrize("bad", [np.zeros((4, 2)), np.zeros((4, 3, 1)), np.zeros(3), np.zeros((4, 3), np.int64),
                                 np.zeros((4, 3), np.float16), "points", None])
def test_points_of_wrong_shape_or_dtype_raise_value_error(bad):
    if bad is None:
        with pytest.raises(ValueError, match=r"expected an \(N, 3\) float32 or float64 array"):
            plumb.KdTree(bad)
        return
    with pytest.raises(ValueError, match=r"PointCloud\.points: expected an \(N, 3\) float32 or float64 array, got"):
        plumb.PointCloud(bad)


def test_field_values_out_of_range_raise_value_error():
    with pytest.raises(ValueError, match=r"PointCloud\.rings: value 65536 at index 1 is out of range \[0, 65535\]"):
        plumb.PointCloud(np.zeros((2, 3)), rings=[0, 65536])
    with pytest.raises(ValueError, match=r"PointCloud\.intensities: expected an \(N,\) float32 or float64 array"):
        plumb.PointCloud(np.zeros((2, 3)), intensities=np.zeros((2, 1)))


def test_inconsistent_cloud_raises_the_cpp_error():
    with pytest.raises(plumb.Error) as info:
        plumb.PointCloud(np.zeros((3, 3)), intensities=[1.0, 2.0])
    assert str(info.value) == "PointCloud: field 'intensities' has 2 entries for 3 points"


def test_trajectory_round_trip_and_validation():
    poses = np.tile(np.eye(4), (3, 1, 1))
    poses[:, 0, 3] = [0.0, 1.0, 2.0]
    traj = plumb.Trajectory(poses, stamps=[0.0, 0.1, 0.2])
    assert len(traj) == 3 and traj.has_stamps()
    assert traj.poses.dtype == np.float64 and traj.poses.shape == (3, 4, 4)
    np.testing.assert_array_equal(traj.poses, poses)
    np.testing.assert_array_equal(traj.stamps, [0.0, 0.1, 0.2])
    traj.push_back(0.3, np.eye(4))
    assert len(traj) == 4
    assert not plumb.Trajectory(poses).has_stamps()
    with pytest.raises(plumb.Error, match=r"^Trajectory: 2 stamps for 3 poses$"):
        plumb.Trajectory(poses, stamps=[0.0, 1.0])
    with pytest.raises(ValueError, match=r"Trajectory\.poses: expected an \(N, 4, 4\) float64 array"):
        plumb.Trajectory(np.zeros((3, 3, 4)))
    bad = poses.copy()
    bad[1, 3, 0] = 1.0
    with pytest.raises(ValueError, match=r"pose 1 is not a rigid transform"):
        plumb.Trajectory(bad)
