"""The local map's hit/miss evidence filter inside LogSlam: a person walking past leaves no trail of points in
the local map (the later scans see through where it was), the walls stay, and the trajectory stays right."""

from __future__ import annotations

import numpy as np

from slam.csm import MatchGrid
from slam.icp import IcpTarget
from slam.log_config import FrontEndConfig, LogSlamConfig
from slam.log_eval import evaluate
from slam.log_slam import LogSlam
from tests.slam import synth


def _built(local_map: tuple[MatchGrid, IcpTarget] | None) -> tuple[MatchGrid, IcpTarget]:
    """The local map, which these scans always have (None only when no scan has returns)."""
    assert local_map is not None
    return local_map


def _walker(k: int) -> np.ndarray:
    """A 0.4 m person crossing the room ahead of the robot, 0.25 m further every scan."""
    return np.array(synth.box(6.0 + 0.25 * k, 8.5, 0.4, 0.4), dtype=np.float64)


def _run(min_log_odds: float | None) -> tuple[LogSlam, np.ndarray, int]:
    rng = np.random.default_rng(5)
    room = synth.room()
    truth = synth.polygon_path([(3.6, 3.0), (18.0, 3.0), (18.0, 12.9), (3.6, 12.9)], 60, 0.2, smooth=5)
    odom = synth.wheel_odometry(truth, rng, slip=0.01, bias=0.005)
    cfg = LogSlamConfig(frontend=FrontEndConfig(local_map_min_log_odds=min_log_odds))
    cfg = cfg.model_copy(update={"loops": cfg.loops.model_copy(update={"enabled": False})})
    slam = LogSlam(cfg, initial_pose=truth[0])
    for k, (p, o) in enumerate(zip(truth, odom, strict=True)):
        scan = synth.raycast(np.vstack([room, _walker(k)]), p, beams=360, noise=0.01, rng=rng, stamp=0.1 * k)
        slam.add_scan(scan, o)
    slam.invalidate_local_map()
    grid, _ = _built(slam._local_map())
    # local-map points on the walker's old positions (scans 0 … n−6: later scans looked through them)
    n = len(truth)
    old = np.array([[6.0 + 0.25 * k, 8.5] for k in range(n - 15, n - 5)])
    pts = np.argwhere(grid.field > 0.99)[:, ::-1] * grid.resolution + grid.origin
    near = int((np.hypot(*(pts[:, None, :] - old[None, :, :]).transpose(2, 0, 1)) < 0.3).any(axis=1).sum())
    return slam, np.array([p.as_tuple() for p in truth]), near


def test_evidence_filter_drops_a_walkers_trail_and_keeps_the_trajectory() -> None:
    plain, truth, trail_plain = _run(None)
    filtered, _, trail_filtered = _run(0.5)
    assert trail_plain >= 5  # without the filter the person's earlier positions are in the local map
    assert trail_filtered == 0
    for slam in (plain, filtered):
        _, est = slam.trajectory()
        assert float(evaluate(est, truth)["ate_rmse"]) < 0.01  # type: ignore[arg-type]
    # the walls are still there: the filtered map scores the last scan as well as the plain one
    last = filtered.points[-1]
    pose = filtered.poses[-1]
    g, _ = _built(filtered._local_map())
    assert g.score(pose, last) > 0.8
