"""LogSlam's local map for a step without odometry (filled surfaces, `slam.surface_fill`) built from the
per-node cache of filled returns equals a build from scratch, after the window slid over many nodes."""

from __future__ import annotations

import numpy as np

from slam.csm import MatchGrid
from slam.icp import IcpTarget
from slam.log_config import FrontEndConfig, LogSlamConfig
from slam.log_slam import LogSlam
from slam.surface_fill import fill_surfaces
from tests.slam import synth


def _built(local_map: tuple[MatchGrid, IcpTarget] | None) -> tuple[MatchGrid, IcpTarget]:
    """The local map, which these scans always have (None only when no scan has returns)."""
    assert local_map is not None
    return local_map


def test_cached_filled_local_map_equals_a_fresh_build() -> None:
    rng = np.random.default_rng(8)
    room = synth.room()
    truth = synth.polygon_path([(3.6, 3.0), (18.0, 3.0), (18.0, 12.9)], 70, 0.2, smooth=5)
    cfg = LogSlamConfig(frontend=FrontEndConfig(local_map_distance=4.0, local_map_scans=8))
    cfg = cfg.model_copy(update={"loops": cfg.loops.model_copy(update={"enabled": False})})
    slam = LogSlam(cfg, initial_pose=truth[0])
    for k, p in enumerate(truth):
        slam.add_scan(synth.raycast(room, p, beams=360, noise=0.01, rng=rng, stamp=0.1 * k))  # no odometry
    assert len(slam._filled) < len(truth)  # nodes that left the window were dropped
    slam.invalidate_local_map()
    grid, _ = _built(slam._local_map(fill=True))
    fe, mp = cfg.frontend, cfg.motion_prior
    fresh = [fill_surfaces(slam.points[k], fe.resolution / 2, mp.fill_ratio, mp.fill_max_gap) for k in slam._local_idx]
    assert all(np.array_equal(slam._filled[int(k)], f) for k, f in zip(slam._local_idx, fresh, strict=True))
    slam._filled.clear()
    slam.invalidate_local_map()
    again, _ = _built(slam._local_map(fill=True))
    assert np.array_equal(grid.field, again.field)
    assert len(slam._local_idx) == 8
