"""Bounded per-scan work on long logs (`slam.loop_batch`): deferred closures are optimised and checked later,
submap grids are released least recently used first, the anchor table follows the estimate."""

from __future__ import annotations

import math

import numpy as np
import pytest

from slam.log_config import LogSlamConfig, LoopConfig
from slam.log_slam import LogSlam
from slam.loop_batch import AnchorTable, BuiltCache, chi2_at


def test_chi2_at_the_estimate_is_the_mahalanobis_distance() -> None:
    poses = [(0.0, 0.0, 0.0), (2.0, 1.0, math.pi / 2)]
    cov = np.diag([0.1 ** 2, 0.2 ** 2, 0.05 ** 2])
    # measured: source 0.1 m further along the target's x axis and 0.05 rad less turned than the estimate
    rel = (2.1, 1.0, math.pi / 2 - 0.05)
    # residual in the measurement's frame: rotate (−0.1, 0) by −(π/2 − 0.05), yaw +0.05
    c, s = math.cos(-(math.pi / 2 - 0.05)), math.sin(-(math.pi / 2 - 0.05))
    r = np.array([c * -0.1, s * -0.1, 0.05])
    assert chi2_at(poses, 0, 1, rel, cov) == pytest.approx(float(r @ np.linalg.solve(cov, r)), rel=1e-9)
    assert chi2_at(poses, 0, 1, (2.0, 1.0, math.pi / 2), cov) == pytest.approx(0.0, abs=1e-20)


class _Item:
    def __init__(self) -> None:
        self.released = False

    def release(self) -> None:
        self.released = True


def test_built_cache_releases_the_least_recently_used() -> None:
    cache, items = BuiltCache(2), [_Item() for _ in range(3)]
    cache.touch(0, items[0])
    cache.touch(1, items[1])
    cache.touch(0, items[0])  # 0 used again: 1 is now the oldest
    cache.touch(2, items[2])
    assert [it.released for it in items] == [False, True, False]


def test_anchor_table_extends_and_follows_a_new_estimate() -> None:
    table, path = AnchorTable(), [0.0, 1.0, 2.0, 3.0]
    poses = [(float(k), 0.0, 0.0) for k in range(4)]
    keys, apath, xy = table.get({0: None, 2: None}, poses, path)
    assert keys.tolist() == [0, 2] and apath.tolist() == [0.0, 2.0] and xy[:, 0].tolist() == [0.0, 2.0]
    keys, apath, xy = table.get({0: None, 2: None, 3: None}, poses, path)  # a submap froze: appended
    assert keys.tolist() == [0, 2, 3] and xy[:, 0].tolist() == [0.0, 2.0, 3.0]
    moved = [(p[0], 5.0, p[2]) for p in poses]  # the estimate was replaced (a loop closure)
    _, _, xy = table.get({0: None, 2: None, 3: None}, moved, path)
    assert xy[:, 1].tolist() == [5.0, 5.0, 5.0]


def _chain(slam: LogSlam, n: int, step: float, believed: float) -> None:
    """n poses whose graph edges say `step` m apart (σ 1 mm) while the front end's list says `believed`."""
    cov = np.diag([1e-6, 1e-6, 1e-8])
    for k in range(n):
        if k == 0:
            slam.graph.add_pose((0.0, 0.0, 0.0))
        else:
            slam.graph.add_pose((k * step, 0.0, 0.0), (step, 0.0, 0.0), cov)
        slam.poses.append((k * believed, 0.0, 0.0))
        slam.path.append(k * believed)


def test_a_deferred_closure_is_optimised_and_checked_at_flush() -> None:
    cfg = LogSlamConfig(loops=LoopConfig(defer_after_nodes=0))
    cov = np.diag([0.03 ** 2, 0.03 ** 2, 0.01 ** 2])
    slam = LogSlam(cfg)
    _chain(slam, 20, 1.0, 1.0)
    c = slam.loops.add(0, 19, (19.0, 0.0, 0.0), cov)  # what the estimate already says: deferred
    assert c.accepted and len(slam.loops.deferred) == 1 and slam.loops.accepted == 1
    k = slam.loops.deferred[0]
    slam.loops.flush()
    assert not slam.loops.deferred and slam.loops.accepted == 1 and slam.graph.chi2(k) < 1
    # the front end believed 1.05 m per step, the graph's edges say 1 m (σ 1 mm): a closure that agrees with the
    # belief is deferred, then found inconsistent once optimised, and taken out again
    slam = LogSlam(cfg)
    _chain(slam, 20, 1.0, 1.05)
    c = slam.loops.add(0, 19, (19 * 1.05, 0.0, 0.0), cov)
    assert c.accepted and slam.loops.deferred
    slam.loops.flush()
    assert slam.loops.accepted == 0 and slam.loops.reasons["inconsistent_after_optimisation"] == 1
    assert slam.poses[19][0] == pytest.approx(19.0, abs=0.01)  # refreshed from the graph
    # past the node threshold only: below it the same closure is optimised at once
    slam = LogSlam(LogSlamConfig())
    _chain(slam, 20, 1.0, 1.05)
    c = slam.loops.add(0, 19, (19 * 1.05, 0.0, 0.0), cov)
    assert not c.accepted and c.reason == "inconsistent_after_optimisation" and not slam.loops.deferred
