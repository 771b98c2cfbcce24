# SPDX-License-Identifier: BSD-3-Clause
"""The pipelines driven from Python against the plumb CLI on the same simulated dump: BimOdometry fed
frame by frame and run_bim_odometry give `plumb run`'s bim.tum byte for byte (the odometry is
deterministic and both write the poses with plumb's TUM writer); run_lio equals `plumb lio`."""

import json
import threading

import numpy as np
import pytest

import plumb


@pytest.fixture(scope="module")
def building(demo_model):
    mesh = plumb.read_ifc(demo_model)
    return mesh, plumb.sample_bim_cloud(mesh, 0.05)


def test_bim_odometry_frame_by_frame_equals_plumb_run(sim_run, building, tmp_path):
    dump_dir, run_dir = sim_run
    mesh, bim_cloud = building
    dump = plumb.FrameDump(dump_dir)
    T_base_lidar = dump.meta.T_base_lidar
    odom = plumb.OdometryInterpolator(dump.odometry())
    frames = ((stamp, plumb.deskew_frame(frame, stamp, T_base_lidar, odom)) for stamp, frame in dump)

    stamp0, frame0 = next(frames)
    start = plumb.BimLocalizer(mesh, bim_cloud).localize(frame0, T_base_lidar)
    assert start.status == plumb.Status.ok
    odometry = plumb.BimOdometry(bim_cloud, start.T_world_base, T_base_lidar=T_base_lidar)
    trajectory = plumb.Trajectory(np.zeros((0, 4, 4)), np.zeros(0))
    results = []
    for stamp, frame in [(stamp0, frame0), *frames]:
        r = odometry.process(frame, stamp, odom.at(stamp))
        assert r.stamp == stamp
        results.append(r)
        trajectory.push_back(stamp, r.T_world_base)
    np.testing.assert_array_equal(odometry.pose, results[-1].T_world_base)
    assert sum(r.anchor.decision == plumb.AnchorDecision.accepted for r in results) > len(results) // 2

    plumb.write_tum(trajectory, tmp_path / "bim.tum")
    assert (tmp_path / "bim.tum").read_bytes() == (run_dir / "bim.tum").read_bytes()
    report = json.loads((run_dir / "report.json").read_text())
    assert report["frames"] == len(results)
    assert report["anchors"]["accepted"] == sum(r.anchor.decision == plumb.AnchorDecision.accepted for r in results)


def test_run_bim_odometry_equals_plumb_run(sim_run, demo_model, tmp_path):
    dump_dir, run_dir = sim_run
    report = plumb.run_bim_odometry(plumb.FrameDump(dump_dir), plumb.read_ifc(demo_model))
    assert report.localized and report.localization_status == plumb.Status.ok and not report.partial
    for name in ("bim", "lidar", "wheel"):
        plumb.write_tum(getattr(report, name), tmp_path / f"{name}.tum")
        assert (tmp_path / f"{name}.tum").read_bytes() == (run_dir / f"{name}.tum").read_bytes(), name
    assert len(report.frames) == report.frames_requested == len(plumb.FrameDump(dump_dir))
    assert report.has_ground_truth and [row.name for row in report.table] == ["P1", "P2", "end"]
    # The report's APE against the truth, recomputed here with numpy.
    truth = plumb.FrameDump(dump_dir).ground_truth().poses[:, :2, 3]
    err = np.linalg.norm(report.bim.poses[:, :2, 3] - truth, axis=1)
    assert report.ape_rmse_bim == pytest.approx(np.sqrt(np.mean(err**2)), rel=1e-9)
    assert report.max_error_bim == pytest.approx(err.max(), rel=1e-12)
    # The slowest frame and the median, recomputed from the frames' own times.
    seconds = np.array([f.seconds_total for f in report.frames])
    assert report.slowest_frame == int(np.argmax(seconds))
    assert report.max_seconds_process == seconds.max()
    assert report.median_seconds_process == np.sort(seconds)[len(seconds) // 2]


def test_run_bim_odometry_settings_and_threads(sim_run, demo_model):
    dump, mesh = plumb.FrameDump(sim_run[0]), plumb.read_ifc(demo_model)
    truth0 = dump.ground_truth().poses[0]
    # Two runs in Python threads (the GIL is released while they run) give the same trajectory.
    reports = [None, None]

    def run(k):
        reports[k] = plumb.run_bim_odometry(dump, mesh, max_frames=20, initial_pose=truth0)

    threads = [threading.Thread(target=run, args=(k,)) for k in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not reports[0].localized and len(reports[0].frames) == 20
    np.testing.assert_array_equal(reports[0].T_world_base0, truth0)
    np.testing.assert_array_equal(reports[0].bim.poses, reports[1].bim.poses)
    with pytest.raises(TypeError, match="RunSettings"):
        plumb.run_bim_odometry(dump, mesh, max_frame=3)


def test_as_built_deviations_equal_plumb_run(sim_run, run_cli, demo_model, building, tmp_path):
    """The as-built estimate from Python: run_bim_odometry's deviation rows are `plumb run --as-built`'s
    deviations.json, and BimOdometry fed frame by frame gives the same rows."""
    dump_dir = sim_run[0]
    done = run_cli("run", dump_dir, "--bim", demo_model, "-o", tmp_path / "cli", "--as-built", "--tolerance", 0.03)
    assert done.returncode == 0, done.stderr
    written = json.loads((tmp_path / "cli" / "deviations.json").read_text())
    settings = plumb.RunSettings()
    settings.deviation_tolerance = 0.03
    settings.odometry.estimate_as_built = True
    report = plumb.run_bim_odometry(plumb.FrameDump(dump_dir), plumb.read_ifc(demo_model), settings=settings)
    assert report.deviation_tolerance == written["tolerance_m"] == 0.03
    assert [r.global_id for r in report.deviations] == [e["global_id"] for e in written["elements"]]
    for row, e in zip(report.deviations, written["elements"]):
        assert row.status.name == e["status"] and row.observations == e["observations"]
        assert row.offset_m == pytest.approx(e["offset_m"], abs=1e-9)
        assert row.sigma_m == pytest.approx(e["sigma_m"], abs=1e-9)
        np.testing.assert_allclose(row.normal, e["normal"], atol=1e-9)
    assert sum(r.status != plumb.DeviationStatus.unobserved for r in report.deviations) > 0
    assert sum(f.as_built_pairs for f in report.frames) > 0

    # Frame by frame, from the same start: the same rows.
    mesh, bim_cloud = building
    dump = plumb.FrameDump(dump_dir)
    odom = plumb.OdometryInterpolator(dump.odometry())
    odometry = plumb.BimOdometry(bim_cloud, report.T_world_base0, T_base_lidar=dump.meta.T_base_lidar,
                                 estimate_as_built=True)
    for stamp, frame in dump:
        odometry.process(plumb.deskew_frame(frame, stamp, dump.meta.T_base_lidar, odom), stamp, odom.at(stamp))
    rows = odometry.deviation_report(mesh, tolerance=0.03)
    assert [(r.global_id, r.status) for r in rows] == [(r.global_id, r.status) for r in report.deviations]
    np.testing.assert_allclose([r.offset_m for r in rows], [r.offset_m for r in report.deviations], atol=1e-12)
    # Without the estimate there is no report to give.
    with pytest.raises(plumb.Error, match="estimate_as_built"):
        plumb.BimOdometry(bim_cloud, report.T_world_base0).deviation_report(mesh)


def test_refined_run_equals_plumb_run_and_a_second_pass_by_hand(sim_run, run_cli, demo_model, building, tmp_path):
    """refine_as_built from Python: run_bim_odometry's bim_refined is `plumb run --as-built --refine`'s
    bim_refined.tum, and a BimOdometry registered by hand to a first pass's estimate gives the same poses."""
    dump_dir = sim_run[0]
    done = run_cli("run", dump_dir, "--bim", demo_model, "-o", tmp_path / "cli", "--as-built", "--refine")
    assert done.returncode == 0, done.stderr
    settings = plumb.RunSettings()
    settings.odometry.estimate_as_built = True
    settings.refine_as_built = True
    report = plumb.run_bim_odometry(plumb.FrameDump(dump_dir), plumb.read_ifc(demo_model), settings=settings)
    plumb.write_tum(report.bim_refined, tmp_path / "bim_refined.tum")
    assert (tmp_path / "bim_refined.tum").read_bytes() == (tmp_path / "cli" / "bim_refined.tum").read_bytes()
    assert report.seconds_refine > 0 and report.max_error_refined > 0
    assert [row.error_refined > 0 for row in report.table] == [True] * 3

    mesh, bim_cloud = building
    dump = plumb.FrameDump(dump_dir)
    odom = plumb.OdometryInterpolator(dump.odometry())
    frames = [(stamp, plumb.deskew_frame(frame, stamp, dump.meta.T_base_lidar, odom)) for stamp, frame in dump]
    kwargs = dict(T_base_lidar=dump.meta.T_base_lidar, threads=1)
    first = plumb.BimOdometry(bim_cloud, report.T_world_base0, estimate_as_built=True, **kwargs)
    for stamp, frame in frames:
        first.process(frame, stamp, odom.at(stamp))
    second = plumb.BimOdometry(bim_cloud, report.T_world_base0, **kwargs)
    second.register_to(first)
    poses = np.array([second.process(frame, stamp, odom.at(stamp)).T_world_base for stamp, frame in frames])
    np.testing.assert_allclose(poses, report.bim_refined.poses, atol=1e-9)
    with pytest.raises(plumb.Error, match="estimate_as_built"):
        second.register_to(second)


def cli_lio_settings(dump):
    """HybridLioSettings as `plumb lio` sets them by default (a map is started by 100 points or more)."""
    settings = plumb.HybridLioSettings()
    settings.features.min_init_points = 100
    settings.features.image.vertical_angles_deg = list(np.degrees(dump.meta.lidar.elevations_rad))
    settings.T_base_lidar = dump.meta.T_base_lidar
    settings.T_base_imu = dump.meta.T_base_imu
    return settings


def test_run_lio_and_hybrid_lio_equal_plumb_lio(sim_run, run_cli, tmp_path):
    dump_dir = sim_run[0]
    frames = 30
    done = run_cli("lio", dump_dir, "-o", tmp_path / "cli", "--max-frames", frames)
    assert done.returncode == 0, done.stderr
    expected = (tmp_path / "cli" / "trajectory.tum").read_bytes()
    dump = plumb.FrameDump(dump_dir)
    settings = cli_lio_settings(dump)

    report = plumb.run_lio(dump, max_frames=frames, lio=settings)
    plumb.write_tum(report.trajectory, tmp_path / "run_lio.tum")
    assert (tmp_path / "run_lio.tum").read_bytes() == expected
    assert report.frames_in(plumb.LioFrameMode.loam) == frames - 1

    # The same loop in Python: the IMU up to the end of each frame's sweep (plus 20 ms), then the frame.
    lio = plumb.HybridLio(dump.ground_truth().poses[0], settings=settings)
    imu, next_imu, sweep = dump.imu(), 0, 1.0 / dump.meta.lidar.rate_hz
    trajectory = plumb.Trajectory(np.zeros((0, 4, 4)), np.zeros(0))
    for i in range(frames):
        stamp = dump.stamp(i)
        while next_imu < len(imu) and imu[next_imu, 0] <= stamp + sweep + 0.02:
            assert lio.add_imu(imu[next_imu, 0], imu[next_imu, 1:4], imu[next_imu, 4:7]) == plumb.Status.ok
            next_imu += 1
        r = lio.process(dump.frame(i), stamp)
        assert r.mode == (plumb.LioFrameMode.init if i == 0 else plumb.LioFrameMode.loam)
        trajectory.push_back(stamp, r.T_world_base)
    plumb.write_tum(trajectory, tmp_path / "hybrid_lio.tum")
    assert (tmp_path / "hybrid_lio.tum").read_bytes() == expected
    np.testing.assert_array_equal(lio.T_world_base, trajectory.poses[-1])


def test_localize_views_of_one_frame_equals_localize_and_more_frames_agree(sim_run, building):
    dump_dir, _ = sim_run
    mesh, bim_cloud = building
    dump = plumb.FrameDump(dump_dir)
    T_base_lidar = dump.meta.T_base_lidar
    gt = dump.ground_truth()
    localizer = plumb.BimLocalizer(mesh, bim_cloud)
    frames = [frame for _, frame in dump][:21]
    alone = localizer.localize(frames[0], T_base_lidar)
    one = localizer.localize_views([frames[0]], [np.eye(4)], T_base_lidar)
    assert one.views == 1 and one.status == alone.status and one.score == alone.score
    np.testing.assert_array_equal(one.T_world_base, alone.T_world_base)
    # Frames 10 and 20 with their true motion from frame 0: the first frame's pose again.
    motions = [np.linalg.inv(gt.poses[0]) @ gt.poses[i] for i in (0, 10, 20)]
    three = localizer.localize_views([frames[i] for i in (0, 10, 20)], motions, T_base_lidar)
    assert three.views == 3 and three.status == plumb.Status.ok
    assert np.linalg.norm(three.T_world_base[:2, 3] - gt.poses[0][:2, 3]) < 0.15
    threaded = plumb.BimLocalizer(mesh, bim_cloud, threads=2)
    again = threaded.localize_views([frames[i] for i in (0, 10, 20)], motions, T_base_lidar)
    np.testing.assert_array_equal(again.T_world_base, three.T_world_base)
    assert again.score == three.score and again.second_score == three.second_score
    with pytest.raises(Exception, match="motions"):
        localizer.localize_views(frames[:2], [np.eye(4)], T_base_lidar)
