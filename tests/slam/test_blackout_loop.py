"""Loop closure after a laser blackout (LoopConfig.blind_*): a simulated CARMEN log drives one lap of the room
with scans, then ~40 m with the laser returning nothing (every beam at the scanner's no-return code) while
the wheel odometry, with a heading bias, drifts ~7 m and 45°, then back into the mapped room. The front end can only
ride the odometry across the gap, so the estimate comes out of it metres off; the usual loop search radius
(capped at `radius_max`, 4 m) cannot reach that far, the blind-path widening can."""

from __future__ import annotations

import math

import numpy as np
import pytest

from slam.log_config import LogSlamConfig
from slam.log_slam import LogSlam
from tests.slam import carmen_synth, synth

STEP = 0.4
LAP = 110  # scans per lap (44 m)
GAP = range(LAP + 10, LAP + 110)  # 40 m blind
N = LAP + 110 + 70
NO_RETURN = 81.91  # a SICK's no-return code, above the reader's 80 m


def _write(path: str, rng: np.random.Generator) -> list[tuple[float, float, float]]:
    truth = carmen_synth.loop(N, STEP)
    odom = synth.wheel_odometry(truth, rng, slip=0.005, bias=0.02)
    lines = []
    for k, (p, o) in enumerate(zip(truth, odom, strict=True)):
        t = 0.5 * k
        lines.append(f"ODOM {o.x:.6f} {o.y:.6f} {o.yaw:.6f} 0.8 0.0 0.0 {t:.6f} synth {t:.6f}")
        line = carmen_synth.flaser_line(p, o, t, rng)
        if k in GAP:
            tok = line.split()
            tok[2:2 + 181] = [f"{NO_RETURN:.2f}"] * 181
            line = " ".join(tok)
        lines.append(line)
    with open(path, "w", encoding="utf-8") as f:
        f.write("\n".join(lines) + "\n")
    return [o.as_tuple() for o in odom]


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, tuple[LogSlam, np.ndarray, float]]:
    path = str(tmp_path_factory.mktemp("blackout") / "blackout.log")
    _write(path, np.random.default_rng(3))
    out = {}
    for name, loops in (("capped", {"blind_radius_rate": 0.0, "blind_yaw_rate": 0.0}), ("default", {})):
        cfg = LogSlamConfig(loops=loops)
        out[name] = carmen_synth.run_scored(path, cfg)
    return out


def _gap_error(slam: LogSlam, ref: np.ndarray) -> float:
    """Position error of the estimate at the gap's end relative to its start, m."""
    from sim.transforms import se2_between

    s, e = GAP[0] - 1, GAP[-1] + 1
    _, est = slam.trajectory()
    d = se2_between(se2_between(tuple(ref[s]), tuple(ref[e])), se2_between(tuple(est[s]), tuple(est[e])))
    return math.hypot(d[0], d[1])


def test_the_blackout_drifts_beyond_the_capped_radius(runs: dict[str, tuple[LogSlam, np.ndarray, float]]) -> None:
    slam, ref, ate = runs["capped"]
    assert slam.stats.odometry_only >= len(GAP)  # the gap really was crossed blind
    assert slam.blind[-1] > 35.0
    assert _gap_error(slam, ref) > 4.0  # the drift stays: no closure within the capped radius
    assert ate > 1.0


def test_blind_widening_closes_the_loop(runs: dict[str, tuple[LogSlam, np.ndarray, float]]) -> None:
    slam, ref, ate = runs["default"]
    assert _gap_error(slam, ref) < 0.1, slam.loops.reasons
    assert ate < 0.05
    # every closure in the final graph agrees with the truth (no alias let in by the wider window)
    from sim.transforms import se2_between

    for c in slam.loops.active.values():
        e = se2_between(se2_between(tuple(ref[c.target]), tuple(ref[c.source])), c.relative)
        assert math.hypot(e[0], e[1]) < 0.3 and abs(e[2]) < math.radians(2)


def _wall(x0: float, y0: float, x1: float, y1: float) -> np.ndarray:
    n = int(math.hypot(x1 - x0, y1 - y0) / 0.05) + 1
    return np.column_stack([np.linspace(x0, x1, n), np.linspace(y0, y1, n)])


def test_a_widened_match_must_stand_out() -> None:
    """`slam.loop_blind.distinct`: in a straight corridor (two walls) a scan fits anywhere along it, so the
    match is rejected; with a cross wall closing one end the fit is unique and accepted."""
    from slam.csm import MatchGrid, search
    from slam.loop_blind import distinct

    corridor = np.vstack([_wall(-15, -1, 15, -1), _wall(-15, 1, 15, 1)])
    closed = np.vstack([corridor, _wall(3, -1, 3, 1)])
    scan = np.vstack([_wall(-4, -1, 2.9, -1), _wall(-4, 1, 2.9, 1), _wall(2.9, -1, 2.9, 1)])  # sensor frame
    scan = scan[::3]
    for world, expected in ((corridor, False), (closed, True)):
        grid = MatchGrid(world, 0.1, 0.1, margin=2 * 6.0 + 1.0)
        guess = (0.4, 0.3, math.radians(5))  # the truth is (0.1, 0, 0)
        res = search(grid, scan, guess, window_xy=6.0, window_yaw=math.radians(40), min_score=0.3)
        assert res is not None
        if expected:
            assert math.hypot(res.pose[0] - 0.1, res.pose[1]) < 0.15 and abs(res.pose[2]) < math.radians(2)
        assert distinct(grid, scan, guess, res.pose, res.score, 6.0, math.radians(40), math.radians(8), 0.9,
                        10.0) is expected
