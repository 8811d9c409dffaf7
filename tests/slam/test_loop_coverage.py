"""Loop candidates by coverage (slam/loop_coverage.py): a hall driven out along one wall and back along the
other, 9 m apart, with a 180° scanner, so the return leg sees the outbound leg's walls from the other side of
the hall, facing the other way. The front end is switched off (every edge is the drifted odometry), so only
loop closures can straighten the trajectory. The default candidates (anchor within radius + submap length,
similar range histogram) find no loop; coverage candidates find them, verified by branch and bound + ICP."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sim.transforms import se2_between
from slam.log_config import LogSlamConfig
from slam.log_slam import LogSlam
from slam.loop_coverage import Coverage
from tests.slam import carmen_synth, synth

W, H = 40.0, 12.0
STEP = 0.4
FRONT_END_OFF = {"min_score": 0.99, "wide_min_score": 0.99}  # no match ever: odometry edges only


def _hall() -> np.ndarray:
    """Walls with recesses and bumps of random width and depth (so places along the hall differ)."""
    segs = [(0.0, 0.0, W, 0.0), (W, 0.0, W, H), (W, H, 0.0, H), (0.0, H, 0.0, 0.0)]
    rng = np.random.default_rng(7)
    for wall_y in (0.0, H):
        x = 1.0
        while x < W - 2:
            w, d = rng.uniform(0.3, 1.5), rng.uniform(0.2, 0.6)
            segs += synth.box(x + w / 2, wall_y, w, 2 * d)
            x += w + rng.uniform(1.0, 4.0)
    return np.array(segs, dtype=np.float64)


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, tuple[LogSlam, np.ndarray, float]]:
    rng = np.random.default_rng(5)
    truth = synth.polygon_path([(2.0, 1.5), (37.0, 1.5), (38.5, H / 2), (37.0, H - 1.5), (2.0, H - 1.5),
                                (0.8, H / 2)], 190, STEP, smooth=5)
    odom = synth.wheel_odometry(truth, rng, slip=0.005, bias=0.003)
    path = tmp_path_factory.mktemp("hall") / "hall.log"
    carmen_synth.write_log(path, truth, odom, rng, segments=_hall(), max_range=20.0)
    out = {}
    for name, loops in (("default", {"coverage": False, "weak_min_score": None, "submap_distance": 4.0}),
                        ("coverage", {"coverage": True})):
        # with the front end off every step is blind: keep the windows capped (the blind widening is
        # tests/slam/test_blackout_loop.py's subject)
        cfg = LogSlamConfig(frontend=FRONT_END_OFF, loops={**loops, "blind_radius_rate": 0.0, "blind_yaw_rate": 0.0})
        out[name] = carmen_synth.run_scored(path, cfg)
    return out


def _across(slam: LogSlam) -> list[tuple[int, int, tuple[float, float, float]]]:
    """Accepted closures from the return leg to the outbound leg (facing the other way)."""
    return [(c.source, c.target, c.relative) for c in slam.loops.history if c.accepted and c.source > 100
            and c.target < 90 and abs(math.remainder(c.relative[2], math.tau)) > math.radians(150)]


def test_default_candidates_miss_the_opposite_revisit(runs: dict[str, tuple[LogSlam, np.ndarray, float]]) -> None:
    slam, _, ate = runs["default"]
    assert slam.stats.odometry_only == len(slam.poses) - 1  # the front end really is off
    assert not _across(slam)
    assert ate > 0.6  # the odometry's drift stays


def test_coverage_closes_the_opposite_revisit(runs: dict[str, tuple[LogSlam, np.ndarray, float]]) -> None:
    slam, ref, ate = runs["coverage"]
    across = _across(slam)
    assert len(across) >= 10, slam.loops.reasons
    # each closure is right up to its submap's own odometry drift (the submaps span 20 m of path built from
    # drifted odometry, and their anchors are up to 20 m from the scan): no corridor alias (≥ 1 m off)
    err = []
    for s, t, rel in across:
        true = se2_between(tuple(ref[t]), tuple(ref[s]))
        err.append(math.hypot(rel[0] - true[0], rel[1] - true[1]))
        assert abs(math.remainder(rel[2] - true[2], math.tau)) < math.radians(2)
    assert max(err) < 0.5 and float(np.median(err)) < 0.3
    assert ate < 0.2 < 0.6 < runs["default"][2]


def test_coverage_counts_points_within_the_radius() -> None:
    wall = np.column_stack([np.linspace(0.0, 10.0, 101), np.zeros(101)])  # 0.1 m apart
    cov = Coverage(wall, 0.25)
    pts = np.array([[5.0, 0.5], [5.0, 1.5], [12.0, 0.0]])  # sensor frame
    assert cov.covered(pts, (0.0, 0.0, 0.0), 1.0).tolist() == [True, False, False]
    # rotated by 90° about the origin and moved by (5, −5): (x, y) → (5 − y, x − 5)
    assert cov.covered(pts, (5.0, -5.0, math.pi / 2), 0.2).tolist() == [True, True, False]  # (4.5, 0), (3.5, 0)
    assert cov.covered(pts, (0.0, -1.0, 0.0), 0.4).tolist() == [False, False, False]  # 0.5 m off the wall
    assert cov.covered(pts, (0.0, -1.0, 0.0), 0.6).tolist() == [True, True, False]
