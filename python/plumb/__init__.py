# SPDX-License-Identifier: BSD-3-Clause
"""plumb: BIM-anchored LiDAR odometry for construction and warehouse robots.

The names of the C++ library in snake_case: point clouds (`PointCloud`, `read_pcd`, `voxel_grid`,
`KdTree`, `estimate_normals`, `align_icp`), trajectories (`Trajectory`, `read_tum`, `read_kitti`)
and their evaluation (`ape`, `rpe`, `align_umeyama`). Points are (N, 3) float32 numpy arrays,
poses 4x4 float64 arrays; `plumb.Error` is raised where the C++ library throws plumb::Error.
See docs/python.md.
"""

from ._plumb import *  # noqa: F401,F403
from ._plumb import __version__  # noqa: F401
