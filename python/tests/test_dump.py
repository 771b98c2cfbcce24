# SPDX-License-Identifier: BSD-3-Clause
"""Frame dumps and the building model, each against the files parsed with numpy / plain Python."""

import json
import re

import numpy as np

import plumb
from pcd_numpy import pcd_header_and_data


def csv_table(path):
    return np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)


def test_frame_dump_streams_equal_the_files(sim_run):
    dump_dir, _ = sim_run
    dump = plumb.FrameDump(dump_dir)
    index = np.loadtxt(dump_dir / "frames.csv", delimiter=",", skiprows=1, usecols=(0, 1))
    assert len(dump) == dump.num_frames() == len(index)
    np.testing.assert_array_equal(dump.stamps, index[:, 1])
    np.testing.assert_array_equal(dump.odometry(), csv_table(dump_dir / "odom.csv"))
    np.testing.assert_array_equal(dump.imu(), csv_table(dump_dir / "imu.csv"))
    np.testing.assert_array_equal(dump.wheels(), csv_table(dump_dir / "wheels.csv"))
    assert dump.has_odometry() and dump.has_imu() and dump.has_wheels() and dump.has_ground_truth()
    gt = np.loadtxt(dump_dir / "gt.tum")
    truth = dump.ground_truth()
    np.testing.assert_array_equal(truth.stamps, gt[:, 0])
    np.testing.assert_allclose(truth.poses[:, :3, 3], gt[:, 1:4], rtol=0, atol=1e-12)


def test_frame_dump_meta_equals_meta_json(sim_run):
    dump_dir, _ = sim_run
    meta_json = json.loads((dump_dir / "meta.json").read_text())
    meta = plumb.FrameDump(dump_dir).meta
    np.testing.assert_array_equal(meta.T_base_lidar, np.array(meta_json["T_base_lidar"]).reshape(4, 4))
    np.testing.assert_array_equal(meta.T_base_imu, np.array(meta_json["T_base_imu"]).reshape(4, 4))
    assert meta.lidar.name == meta_json["lidar"]["name"]
    assert meta.lidar.rate_hz == meta_json["lidar"]["rate_hz"]
    np.testing.assert_array_equal(meta.lidar.elevations_rad, meta_json["lidar"]["elevations_rad"])
    assert meta.axle == meta_json["axle"] and meta.imu_rate_hz == meta_json["imu_rate_hz"]
    assert meta.model == meta_json["model"] and meta.source == meta_json["source"]


def test_frame_dump_iterates_frames_with_their_fields(sim_run):
    dump_dir, _ = sim_run
    dump = plumb.FrameDump(dump_dir)
    dtype = np.dtype([("xyz", "<f4", 3), ("intensity", "<f4"), ("ring", "<u2"), ("time", "<f4"), ("label", "<i4")])
    seen = 0
    for i, (stamp, frame) in enumerate(dump):
        if i % 40 == 0:
            header, data = pcd_header_and_data(dump.frame_path(i))
            assert header["FIELDS"] == ["x", "y", "z", "intensity", "ring", "time", "label"]
            ref = np.frombuffer(data[: int(header["POINTS"][0]) * dtype.itemsize], dtype=dtype)
            assert stamp == dump.stamp(i)
            assert frame.points.dtype == np.float32 and frame.points.shape == (len(ref), 3)
            np.testing.assert_array_equal(frame.points, ref["xyz"])
            np.testing.assert_array_equal(frame.intensities, ref["intensity"])
            np.testing.assert_array_equal(frame.rings, ref["ring"])
            np.testing.assert_array_equal(frame.times, ref["time"])
            np.testing.assert_array_equal(frame.labels, ref["label"])
        seen += 1
    assert seen == len(dump)


def test_odometry_interpolator_and_deskew(sim_run):
    dump = plumb.FrameDump(sim_run[0])
    table = dump.odometry()
    odom = plumb.OdometryInterpolator(table)
    np.testing.assert_array_equal(odom.at(table[10, 0]), table[10, 1:])
    mid = 0.5 * (table[10] + table[11])
    np.testing.assert_allclose(odom.at(mid[0])[:2], mid[1:3], atol=1e-6)
    # Deskewing moves a point by the base's motion since the stamp: none for a point at time 0.
    frame = dump.frame(50)
    still = plumb.PointCloud(frame.points[:5], times=np.zeros(5, np.float32))
    moved = plumb.PointCloud(frame.points[:5], times=np.full(5, -0.05, np.float32))
    T_bl = dump.meta.T_base_lidar
    np.testing.assert_array_equal(plumb.deskew_frame(still, dump.stamp(50), T_bl, odom).points, still.points)
    assert np.all(np.linalg.norm(plumb.deskew_frame(moved, dump.stamp(50), T_bl, odom).points - moved.points, axis=1) > 0)


def ifc_entities(path, entity):
    """The lines of one IFC entity type: (express id, GlobalId)."""
    text = path.read_text()
    return re.findall(r"^#(\d+)\s*=\s*" + entity + r"\('([^']*)'", text, flags=re.MULTILINE)


def test_read_ifc_elements_equal_the_file(demo_model):
    mesh = plumb.read_ifc(demo_model)
    for entity, name in (("IFCWALL", "IfcWall"), ("IFCDOOR", "IfcDoor"), ("IFCWINDOW", "IfcWindow"),
                         ("IFCSLAB", "IfcSlab"), ("IFCCOLUMN", "IfcColumn"), ("IFCSPACE", "IfcSpace")):
        expected = {(int(eid), gid) for eid, gid in ifc_entities(demo_model, entity)}
        got = {(e.express_id, e.global_id) for e in mesh.elements if e.type == name}
        assert got == expected and expected, name
    assert [s.name for s in mesh.storeys] == [
        re.search(r"'[^']*',[^,]*,'([^']*)'", line).group(1)
        for line in demo_model.read_text().splitlines() if "IFCBUILDINGSTOREY(" in line]
    # The C++ default leaves rooms out; read_ifc meshes them unless told.
    assert not any(e.type == "IfcSpace" for e in plumb.read_ifc(demo_model, include_spaces=False).elements)


def test_read_ifc_mesh_arrays(demo_model):
    mesh = plumb.read_ifc(demo_model)
    v, t, te = mesh.vertices, mesh.triangles, mesh.triangle_element
    assert v.dtype == np.float64 and v.shape[1] == 3
    assert t.dtype == np.uint32 and t.shape == (mesh.num_triangles(), 3) and t.max() < len(v)
    assert te.dtype == np.int32 and te.shape == (len(t),)
    for k, e in enumerate(mesh.elements):
        np.testing.assert_array_equal(te[e.first_triangle:e.first_triangle + e.num_triangles], k)
        corners = v[t[e.first_triangle:e.first_triangle + e.num_triangles].ravel()]
        if e.num_triangles:
            np.testing.assert_allclose(corners.min(axis=0), e.bbox_min, atol=1e-9)
            np.testing.assert_allclose(corners.max(axis=0), e.bbox_max, atol=1e-9)
    lo, hi = mesh.bounds()
    np.testing.assert_array_equal(lo, v.min(axis=0))
    np.testing.assert_array_equal(hi, v.max(axis=0))


def test_sampled_clouds_lie_on_their_elements(demo_model):
    mesh = plumb.read_ifc(demo_model)
    v, t = mesh.vertices, mesh.triangles
    for cloud in (plumb.sample_bim_cloud(mesh, 0.1), plumb.sample_surface(mesh, spacing=0.2, types=["IfcWall"])):
        assert len(cloud) > 1000 and cloud.has_normals() and cloud.has_labels()
        for p, n, label in zip(cloud.points[::97], cloud.normals[::97], cloud.labels[::97]):
            e = mesh.elements[label]
            tri = v[t[e.first_triangle:e.first_triangle + e.num_triangles]]
            normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
            normal /= np.linalg.norm(normal, axis=1, keepdims=True)
            plane_dist = np.abs(np.einsum("ij,ij->i", normal, p - tri[:, 0]))
            assert plane_dist.min() < 1e-4
            assert abs(abs(normal[np.argmin(plane_dist)] @ n) - 1) < 1e-4
    walls = plumb.sample_surface(mesh, spacing=0.2, types=["IfcWall"])
    assert {mesh.elements[k].type for k in np.unique(walls.labels)} == {"IfcWall"}
    assert {mesh.elements[k].type for k in np.unique(plumb.sample_bim_cloud(mesh, 0.1).labels)}.isdisjoint(
        {"IfcDoor", "IfcWindow", "IfcSpace"})
