# SPDX-License-Identifier: BSD-3-Clause
"""voxel_grid, KdTree and estimate_normals against numpy brute force; align_icp against known and
published transforms."""

import numpy as np
import pytest

import plumb


def voxel_groups(points, leaf):
    """Voxel coordinates and the points of each voxel, in plumb's order (i_z, i_y, i_x ascending),
    with the grid anchored at the bounding-box minimum."""
    p = points.astype(np.float64)
    ijk = np.floor((p - p.min(axis=0)) / leaf).astype(np.int64)
    keys, inverse = np.unique(ijk[:, ::-1], axis=0, return_inverse=True)
    return keys, inverse.reshape(-1)


def test_voxel_grid_centroids_match_numpy_averages(data_path):
    cloud = plumb.read_pcd(data_path("cloud3d/hdl32_pair/251370668.pcd"))
    points = cloud.points[np.isfinite(cloud.points).all(axis=1)]
    keys, inverse = voxel_groups(points, 0.5)
    counts = np.bincount(inverse)
    mean = np.stack([np.bincount(inverse, weights=points[:, a].astype(np.float64)) for a in range(3)], axis=1)
    mean /= counts[:, None]
    result = plumb.voxel_grid(plumb.PointCloud(points), leaf_size=0.5, mode=plumb.VoxelMode.centroid)
    assert result.status == plumb.Status.ok
    assert result.num_voxels == len(keys) and len(result.cloud) == len(keys)
    assert result.indices.shape == (0,)
    np.testing.assert_allclose(result.cloud.points, mean, rtol=0, atol=1e-5)


def test_voxel_grid_nearest_to_centroid_keeps_the_nearest_real_point(data_path):
    cloud = plumb.read_pcd(data_path("cloud3d/pcl_test/bunny.pcd"))
    points = cloud.points
    leaf = 0.01
    result = plumb.voxel_grid(points, leaf_size=leaf, min_points_per_voxel=2)
    keys, inverse = voxel_groups(points, leaf)
    counts = np.bincount(inverse)
    assert result.num_voxels == len(keys)
    assert result.num_sparse_voxels == int((counts < 2).sum())
    expected = []
    for v in np.flatnonzero(counts >= 2):
        members = np.flatnonzero(inverse == v)
        centroid = points[members].astype(np.float64).mean(axis=0)
        d = ((points[members].astype(np.float64) - centroid) ** 2).sum(axis=1)
        expected.append(members[np.argmin(d)])
    np.testing.assert_array_equal(result.indices, expected)
    np.testing.assert_array_equal(result.cloud.points, points[expected])


def test_voxel_grid_errors():
    with pytest.raises(plumb.Error, match=r"^voxel_grid: leaf_size must be finite and > 0, got -1 m$"):
        plumb.voxel_grid(np.zeros((3, 3)), leaf_size=-1.0)
    with pytest.raises(TypeError, match=r"voxel_grid\(\) got an unexpected keyword argument 'leaf'"):
        plumb.voxel_grid(np.zeros((3, 3)), leaf=1.0)
    empty = plumb.voxel_grid(np.zeros((0, 3), np.float32))
    assert empty.status == plumb.Status.insufficient_data and len(empty.cloud) == 0


def brute_force(points, queries):
    diff = queries[:, None, :].astype(np.float64) - points[None, :, :].astype(np.float64)
    return (diff ** 2).sum(axis=2)


def test_kdtree_knn_matches_brute_force():
    rng = np.random.default_rng(4)
    points = rng.uniform(-10, 10, size=(3000, 3)).astype(np.float32)
    queries = rng.uniform(-11, 11, size=(200, 3))
    tree = plumb.KdTree(points)
    assert len(tree) == 3000
    indices, sq_dists = tree.knn(queries, 8)
    assert indices.shape == (200, 8) and indices.dtype == np.int64 and sq_dists.dtype == np.float32
    d = brute_force(points, queries)
    ref = np.argsort(d, axis=1)[:, :8]
    np.testing.assert_array_equal(indices, ref)
    np.testing.assert_allclose(sq_dists, np.take_along_axis(d, ref, axis=1), rtol=1e-5, atol=1e-6)
    one_idx, one_d = tree.knn(queries[0], 3)
    np.testing.assert_array_equal(one_idx, ref[0, :3])
    assert one_d.shape == (3,)
    assert tree.nearest(queries[0])[0] == ref[0, 0]


def test_kdtree_radius_and_non_finite_queries():
    rng = np.random.default_rng(5)
    points = rng.uniform(0, 1, size=(2000, 3)).astype(np.float32)
    points[7] = np.nan
    tree = plumb.KdTree(points, leaf_size=4, split=plumb.KdTreeSplit.midpoint)
    assert len(tree) == 1999 and tree.num_skipped() == 1
    query = np.array([0.5, 0.5, 0.5])
    indices, sq_dists = tree.radius(query, 0.2)
    d = brute_force(np.nan_to_num(points, nan=1e9), query[None])[0]
    assert sorted(indices.tolist()) == np.flatnonzero(d <= 0.04).tolist()
    assert (np.diff(sq_dists) >= 0).all()
    idx, dist = tree.knn(np.array([[np.nan, 0, 0], [0.5, 0.5, 0.5]]), 2)
    assert idx[0].tolist() == [-1, -1] and np.isinf(dist[0]).all()
    assert (idx[1] >= 0).all()
    assert tree.knn(query, 5000)[0].shape == (1999,)
    with pytest.raises(plumb.Error):
        plumb.KdTree(np.full((3, 3), np.nan))
    with pytest.raises(ValueError, match=r"KdTree\.radius: query: expected a \(3,\) float32 or float64 array"):
        tree.radius(np.zeros(2), 1.0)


def test_estimate_normals_match_numpy_pca():
    rng = np.random.default_rng(6)
    xy = rng.uniform(-1, 1, size=(500, 2))
    z = 0.3 * xy[:, 0] ** 2 - 0.2 * xy[:, 1] + rng.normal(scale=0.01, size=500)
    points = np.column_stack([xy, z]).astype(np.float32)
    viewpoint = np.array([0.0, 0.0, 5.0])
    result = plumb.estimate_normals(points, k=12, viewpoint=viewpoint)
    assert result.num_invalid == 0 and result.normals.shape == (500, 3)
    d = brute_force(points, points)
    for i in range(0, 500, 7):
        nb = points[np.argsort(d[i])[:12]].astype(np.float64)
        w, v = np.linalg.eigh(np.cov(nb.T, bias=True))
        n = v[:, 0] * (1 if v[:, 0] @ (viewpoint - points[i]) >= 0 else -1)
        assert result.normals[i] @ n > 0.9999
        assert result.curvature[i] == pytest.approx(w[0] / w.sum(), rel=1e-3, abs=1e-6)
    tree = plumb.KdTree(points)
    with_tree = plumb.estimate_normals(points[:10], tree, k=12, viewpoint=viewpoint)
    np.testing.assert_allclose(with_tree.normals, result.normals[:10], atol=1e-6)


def rotation_z(angle):
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def test_align_icp_recovers_a_known_transform(data_path):
    target = plumb.read_pcd(data_path("cloud3d/pcl_test/bunny.pcd")).points
    T = np.eye(4)
    T[:3, :3] = rotation_z(0.05)
    T[:3, 3] = [0.01, -0.005, 0.003]
    source = ((target.astype(np.float64) - T[:3, 3]) @ T[:3, :3]).astype(np.float32)  # T^-1 * target
    result = plumb.align_icp(source, target, max_correspondence_distance=0.05, min_correspondence_distance=0.01,
                             distance_step=0.01, overlap_distance=0.005, tolerance=1e-12, min_step=1e-9,
                             max_iterations=200)
    assert result.status == plumb.Status.ok and result.converged
    assert result.T_target_source.shape == (4, 4) and result.T_target_source.dtype == np.float64
    np.testing.assert_allclose(result.T_target_source, T, atol=1e-4)
    assert result.rmse < 1e-4 and result.overlap > 0.99 and result.iterations > 0
    assert result.normal_matrix.shape == (6, 6)


def test_align_icp_point_to_plane_matches_the_reference_relative_pose(data_path):
    # fast_gicp's pair: relative.txt is T_target_source of 251371071 (source) against 251370668 (target).
    target = plumb.read_pcd(data_path("cloud3d/hdl32_pair/251370668.pcd"))
    source = plumb.read_pcd(data_path("cloud3d/hdl32_pair/251371071.pcd"))
    reference = np.loadtxt(data_path("cloud3d/hdl32_pair/relative.txt"))
    target.normals = plumb.estimate_normals(target.points, k=20, radius=0.5).normals
    settings = plumb.IcpSettings()
    settings.method = plumb.IcpMethod.point_to_plane
    settings.distance_step = 0.3
    settings.min_overlap = 0.8
    settings.overlap_distance = 0.2
    settings.kernel = plumb.RobustKernel.huber
    settings.kernel_scale = 0.1
    gated = plumb.align_icp(source, target, settings=settings)
    assert gated.status == plumb.Status.ok
    fine = plumb.align_icp(source, target, gated.T_target_source, settings=settings, max_correspondence_distance=0.1,
                           min_overlap=0.0, keep_correspondences=True)
    error = np.linalg.inv(reference) @ fine.T_target_source
    assert np.linalg.norm(error[:3, 3]) < 0.05
    angle = np.arccos(np.clip((np.trace(error[:3, :3]) - 1) / 2, -1, 1))
    assert angle < np.radians(0.3)
    assert len(fine.correspondences) == fine.num_inliers > 0


def test_align_icp_errors_carry_the_cpp_message():
    points = np.random.default_rng(7).normal(size=(100, 3))
    with pytest.raises(plumb.Error, match=r"normals"):
        plumb.align_icp(points, points, method=plumb.IcpMethod.point_to_plane)
    with pytest.raises(ValueError, match=r"align_icp: T_init: expected a rigid transform"):
        plumb.align_icp(points, points, np.zeros((4, 4)))
    with pytest.raises(ValueError, match=r"align_icp: T_init: expected a 4x4 float64 array"):
        plumb.align_icp(points, points, np.eye(3))


def test_threads_give_the_one_thread_results(data_path):
    # The `threads` setting reaches the C++ loops (a bad count is refused by them) and, as there,
    # changes no result: normals, FPFH and ICP bit for bit.
    room = plumb.read_pcd(data_path("cloud3d/pcl_room_scans/room_scan1.pcd"), drop_non_finite=True)
    cloud = plumb.voxel_grid(room, leaf_size=0.1).cloud
    one = plumb.estimate_normals(cloud.points, k=15)
    two = plumb.estimate_normals(cloud.points, k=15, threads=2)
    np.testing.assert_array_equal(one.normals, two.normals)
    cloud.normals = one.normals
    np.testing.assert_array_equal(plumb.compute_fpfh(cloud, radius=0.5).features,
                                  plumb.compute_fpfh(cloud, radius=0.5, threads=3).features)
    T = np.eye(4)
    T[:3, :3] = rotation_z(0.03)
    T[:3, 3] = [0.1, -0.05, 0.0]
    source = ((cloud.points.astype(np.float64) - T[:3, 3]) @ T[:3, :3]).astype(np.float32)
    a = plumb.align_icp(source, cloud.points, max_correspondence_distance=0.5)
    b = plumb.align_icp(source, cloud.points, max_correspondence_distance=0.5, threads=2)
    assert a.status == plumb.Status.ok
    np.testing.assert_array_equal(a.T_target_source, b.T_target_source)
    with pytest.raises(plumb.Error, match="threads"):
        plumb.compute_fpfh(cloud, radius=0.5, threads=-1)
    with pytest.raises(plumb.Error, match="threads"):
        plumb.estimate_normals(cloud.points, k=15, threads=-1)
