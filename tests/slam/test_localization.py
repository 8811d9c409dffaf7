"""Localisation in a known map converges from a wrong start and recovers after a kidnapping."""

from __future__ import annotations

import math

import numpy as np
import pytest

from planning.grid import OccupancyGrid
from sim.transforms import se2_between, se2_compose
from sim.types import Pose2D
from slam.localization import Localizer
from slam.mapping import OccupancyMapper
from slam.types import LocalizationConfig, LocalizationEstimate
from tests.slam import synth

SEGS = synth.room()


@pytest.fixture(scope="module")
def room_map() -> OccupancyGrid:
    m = OccupancyMapper(resolution=0.05)
    rng = np.random.default_rng(0)
    for p in synth.loop_path(400, 0.12)[::4]:
        scan = synth.raycast(SEGS, p, noise=0.01, rng=rng)
        m.integrate(p.as_tuple(), scan.points(), scan.angles()[~np.isfinite(scan.ranges)])
    return m.grid()


def _run(grid: OccupancyGrid, path: list[Pose2D], jump_at: int | None, start: Pose2D, seed: int = 1,
         config: LocalizationConfig | None = None) -> tuple[np.ndarray, list[LocalizationEstimate]]:
    """Wheel odometry follows the robot's real motion but not the teleport (a zero increment there)."""
    rng = np.random.default_rng(seed)
    odo = [path[0].as_tuple()]
    for k in range(1, len(path)):
        d = (0.0, 0.0, 0.0) if k == jump_at else se2_between(path[k - 1].as_tuple(), path[k].as_tuple())
        odo.append(se2_compose(odo[-1], (d[0] * (1 + rng.normal(0, 0.02)), d[1], d[2] * (1 + rng.normal(0, 0.02)))))
    loc = Localizer(grid, config, seed=seed)
    loc.initialize(start)
    errs, ests = [], []
    for k, p in enumerate(path):
        est = loc.update(synth.raycast(SEGS, p, noise=0.01, rng=rng, stamp=0.1 * k), Pose2D(*odo[k]))
        errs.append(math.hypot(est.pose.x - p.x, est.pose.y - p.y))
        ests.append(est)
    return np.array(errs), ests


def test_converges_from_a_wrong_start_and_tracks(room_map: OccupancyGrid) -> None:
    path = synth.loop_path(120, 0.1)
    start = Pose2D(path[0].x + 0.3, path[0].y - 0.2, path[0].yaw + 0.15)
    errs, ests = _run(room_map, path, None, start)
    assert errs[0] > 0.01 or ests[0].refined  # (ICP may already fix the very first estimate)
    assert np.sqrt(np.mean(errs[10:] ** 2)) < 0.03
    q = ests[-1].quality
    assert q.converged and q.spread_xy < 0.1 and q.match_score > 0.8 and q.ambiguity < 0.1


def test_recovers_after_a_kidnapping(room_map: OccupancyGrid) -> None:
    loop = synth.loop_path(700, 0.1)
    jump = 60
    path = loop[:jump] + loop[jump + 350:]
    errs, ests = _run(room_map, path, jump, loop[0])
    assert errs[jump] > 2.0 and ests[jump + 1].quality.match_score < 0.5  # it noticed
    recovered = [k for k in range(jump, len(path) - 10) if (errs[k:k + 10] < 0.05).all()]
    assert recovered and recovered[0] - jump <= 40  # within 4 s of sim time at 10 Hz
    assert any(e.injected > 0 for e in ests[jump:jump + 20])  # by augmented-MCL injection
    assert np.sqrt(np.mean(errs[recovered[0]:] ** 2)) < 0.03


def test_without_injection_the_kidnapped_filter_stays_lost(room_map: OccupancyGrid) -> None:
    """The recovery above is the injection's doing: switch it off (alpha_fast = alpha_slow) and it fails."""
    loop = synth.loop_path(700, 0.1)
    jump = 60
    path = loop[:jump] + loop[jump + 350:jump + 450]
    cfg = LocalizationConfig(alpha_slow=0.1, alpha_fast=0.1)
    errs, _ = _run(room_map, path, jump, loop[0], config=cfg)
    assert (errs[-20:] > 0.5).all()
