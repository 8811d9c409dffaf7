"""SlamPipeline bookkeeping: one trajectory entry per scan, status, lazy map re-render after a loop closes."""

from __future__ import annotations

import math

import numpy as np

from sim.types import LidarScan
from slam.metrics import trajectory_errors
from slam.pipeline import SlamPipeline
from tests.slam import synth


def test_status_trajectory_and_map_rerender() -> None:
    rng = np.random.default_rng(2)
    segs = synth.room()
    truth = synth.loop_path(520, 0.1)  # one lap (≈ 47 m) and a bit: comes back past the start
    wheel = synth.wheel_odometry(truth, rng)
    slam = SlamPipeline(robot="r9", initial_pose=truth[0])
    for k, (p, o) in enumerate(zip(truth, wheel, strict=True)):
        scan = synth.raycast(segs, p, noise=0.01, rng=rng, stamp=0.1 * k)
        if k == 100:  # a blinded lidar: no returns at all
            scan = LidarScan("synth", scan.stamp, scan.angle_min, scan.angle_increment, 0.1, 10.0,
                             np.full(scan.ranges.size, np.inf))
        slam.process_scan(scan, o)
    st = slam.status()
    assert st.robot == "r9" and st.scans == len(truth) and st.skipped_scans == 1
    assert st.loop_closures_accepted >= 1
    # the closures here moved no pose by more than half a cell, so the map stayed incremental
    assert st.map_current
    stamps, est = slam.trajectory()
    assert len(stamps) == len(truth) and stamps[100] == 10.0
    assert trajectory_errors(est, np.array([p.as_tuple() for p in truth]), align=False).ate_rmse < 0.03
    assert math.hypot(st.pose.x - truth[-1].x, st.pose.y - truth[-1].y) < 0.05
    slam.batch_optimize()  # Levenberg-Marquardt over everything: poses may move, so the map is re-rendered
    assert not slam.status().map_current
    grid = slam.map()
    assert slam.status().map_current and grid.occupied().sum() > 500
