# SPDX-License-Identifier: BSD-3-Clause
"""plumb: BIM-anchored LiDAR odometry for construction and warehouse robots.

The names of the C++ library in snake_case: point clouds (`PointCloud`, `read_pcd`, `voxel_grid`,
`KdTree`, `estimate_normals`, `align_icp`, `compute_fpfh`, `align_sac_ia`, `segment_frame`),
trajectories (`Trajectory`, `read_tum`, `read_kitti`) and their evaluation (`ape`, `rpe`,
`align_umeyama`), frame dumps (`FrameDump`), the building model (`read_ifc`, `sample_bim_cloud`),
the pipelines (`BimLocalizer`, `BimOdometry`, `HybridLio`, `run_bim_odometry`, `run_lio`) and
planar scans (`cloud_to_scan`, `plicp`, `calibrate_odometry_laser`). Points are (N, 3) float32 numpy arrays,
poses 4x4 float64 arrays; `plumb.Error` is raised where the C++ library throws plumb::Error.
See docs/python.md.
"""

from ._plumb import *  # noqa: F401,F403
from ._plumb import __version__  # noqa: F401
