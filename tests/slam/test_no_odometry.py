"""SLAM without odometry (Radish orebro-like keyframe logs): same-surface gap filling, the score-surface
covariance of a correlative match (degenerate along a corridor, closed form), the motion prior, and a
simulated log with no odometry at all, scans 1 m apart, mapped within a stated ATE; a weak wrong wide match
settled by the next scan."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from sim.transforms import se2_compose
from sim.types import Pose2D
from slam import se2
from slam.csm import CsmResult, MatchGrid
from slam.hypotheses import HypothesesConfig, WideSearch, decide
from slam.log_config import LogSlamConfig
from slam.log_eval import evaluate
from slam.log_run import load_log, run_slam
from slam.match_covariance import MatchCovarianceConfig, ambiguous_covariance, score_covariance
from slam.motion_prior import at_window_edge, predicted_step
from slam.surface_fill import fill_surfaces
from tests.slam import carmen_synth, synth


def test_fill_surfaces_walls_not_depth_jumps() -> None:
    # a wall x = 10 seen by 1° beams over ±40°: returns 17–28 cm apart; filled every 2.5 cm, all on the wall
    ang = np.radians(np.arange(-40, 41, 1.0))
    wall = np.column_stack([np.full(ang.size, 10.0), 10.0 * np.tan(ang)])
    out = fill_surfaces(wall, step=0.025)
    assert np.allclose(out[:, 0], 10.0, atol=1e-9)
    ys = np.sort(out[:, 1])
    gaps = np.diff(wall[:, 1])
    assert np.diff(ys).max() <= 0.025 + 1e-9 and len(out) == len(wall) + int(np.sum(np.ceil(gaps / 0.025) - 1))
    # a depth jump between two beams 1° apart (a door frame at 3 m in front of a wall at 6 m) stays open
    jump = np.array([[3.0, 0.0], [6.0 * math.cos(0.0175), 6.0 * math.sin(0.0175)]])
    assert len(fill_surfaces(jump)) == 2


def _corridor_grid() -> MatchGrid:
    x = np.arange(-30.0, 30.0, 0.01)
    return MatchGrid(np.vstack([np.column_stack([x, np.full_like(x, 1.0)]),
                                np.column_stack([x, np.full_like(x, -1.0)])]), 0.05, 0.07, margin=1.0)


def test_corridor_match_is_degenerate_along_it() -> None:
    grid = _corridor_grid()
    x = np.arange(-5.0, 5.0, 0.05)
    scan = np.vstack([np.column_stack([x, np.full_like(x, 1.0)]), np.column_stack([x, np.full_like(x, -1.0)])])
    cfg = MatchCovarianceConfig()
    pose = (0.0125, 0.0125, 0.0)  # a cell centre: every lattice shift along x scores the same
    cov = score_covariance(grid, scan, pose, 2.5, 0.3, cfg)
    n = math.floor(2.5 / cfg.step)  # every shift k·step (|k| ≤ n) along the corridor is as good: E[k²]·step²
    assert cov[0, 0] == pytest.approx(cfg.step ** 2 * n * (n + 1) / 3, rel=1e-6)
    assert math.sqrt(cov[1, 1]) < 0.05 and math.sqrt(cov[2, 2]) < 0.05
    # in the edge frame of a pose facing along +y (yaw 90°) the corridor (world x) is the edge's y axis
    facing = (pose[0], pose[1], math.pi / 2)
    in_sensor = np.column_stack([scan[:, 1] - pose[1], -(scan[:, 0] - pose[0])])  # R(−90°)·(world − t)
    turned = ambiguous_covariance(grid, in_sensor, facing, 2.5, 0.3, cfg)
    assert turned is not None and turned[1, 1] == pytest.approx(cov[0, 0], rel=1e-6) and turned[0, 0] < 0.05 ** 2


def test_closed_room_match_is_not_ambiguous() -> None:
    side = np.arange(-2.0, 2.0, 0.01)
    c = np.full_like(side, 2.0)
    walls = np.vstack([np.column_stack([side, c]), np.column_stack([side, -c]),
                       np.column_stack([c, side]), np.column_stack([-c, side])])
    grid = MatchGrid(walls, 0.05, 0.07, margin=3.0)
    cfg = MatchCovarianceConfig()
    cov = score_covariance(grid, walls[::10], (0.0125, 0.0125, 0.0), 2.5, 0.3, cfg)
    assert math.sqrt(max(np.linalg.eigvalsh(cov[:2, :2]))) < 0.1
    assert ambiguous_covariance(grid, walls[::10], (0.0125, 0.0125, 0.0), 2.5, 0.3, cfg) is None


def test_motion_prior() -> None:
    poses = [(0.0, 0.0, 0.0), (1.0, 0.0, math.pi / 2), (1.0, 1.0, math.pi / 2)]
    assert predicted_step(poses) == pytest.approx((1.0, 0.0, 0.0), abs=1e-12)  # the last step, own frame
    assert predicted_step(poses, constant_velocity=False) == (0.0, 0.0, 0.0)
    assert predicted_step(poses[:1]) == (0.0, 0.0, 0.0)
    g = (1.0, 1.0, 0.0)
    assert not at_window_edge((2.0, 1.0, 0.5), g, 2.5, 1.5, 0.05, 0.03)
    assert at_window_edge((3.48, 1.0, 0.0), g, 2.5, 1.5, 0.05, 0.03)
    assert at_window_edge((1.0, 1.0, -1.49), g, 2.5, 1.5, 0.05, 0.03)


def test_log_without_odometry_is_mapped(tmp_path: Path) -> None:
    # one 44 m lap of the simulated room and back past the start, a scan every 1 m, no odometry at all
    rng = np.random.default_rng(5)
    truth = carmen_synth.loop(52, 1.0)
    path = tmp_path / "keyframes.log"
    carmen_synth.write_log(path, truth, truth, rng)
    cfg = LogSlamConfig(odometry="none")
    log = load_log(path, cfg)
    assert log.reference is not None and not log.odom_valid.any()
    slam = run_slam(log, cfg)
    _, est = slam.trajectory()
    ate = float(evaluate(est, log.reference)["ate_rmse"])  # type: ignore[arg-type]
    assert ate < 0.05, ate
    assert slam.stats.wide == len(truth) - 1 - slam.stats.odometry_only


def _points(pose: Pose2D) -> np.ndarray:
    return synth.raycast(carmen_synth.SEGS, pose, beams=360, max_range=10.0).points()[::3]


def test_a_weak_wrong_match_is_settled_by_the_next_scan() -> None:
    # the room mapped from three poses; scan k truly 1 m further along x, scan k+1 1 m beyond. The wide search
    # "found" scan k turned 70° (a weak, wrong match); the prediction (1 m on) is right, and the next scan
    # matches from it, not from the wrong turn.
    poses = [Pose2D(4.0 + 0.5 * i, 3.0, 0.0) for i in range(3)]
    world = np.vstack([se2.transform_points(p.as_tuple(), _points(p)) for p in poses])
    grid = MatchGrid(world, 0.05, 0.07, margin=3.0)
    prev = poses[-1].as_tuple()
    truth, nxt = Pose2D(6.0, 3.0, 0.0), Pose2D(7.0, 3.0, 0.0)
    pts, next_pts = _points(truth), _points(nxt)
    wrong = (6.0, 3.0, 1.2)
    best = CsmResult(wrong, grid.score(wrong, pts), 0)
    assert best.score < grid.score(truth.as_tuple(), pts)  # (a real search would not pick it: staged)
    wide = WideSearch(2.5, math.radians(85), 0.25, 0.01, 0.01)
    guess = se2_compose(prev, (1.0, 0.0, 0.0))
    out = decide(grid, pts, best, prev, guess, next_pts, wide, HypothesesConfig())
    assert out is not None
    assert math.hypot(out.pose[0] - 6.0, out.pose[1] - 3.0) < 0.1 and abs(out.pose[2]) < 0.05
    # a match scoring above `below` is kept as it is (no second hypothesis)
    assert decide(grid, pts, best, prev, guess, next_pts, wide, HypothesesConfig(below=best.score)) is best
    assert decide(grid, pts, best, prev, guess, None, wide, HypothesesConfig()) is best
