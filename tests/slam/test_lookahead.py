"""Near-tied corridor peaks decided by the following scans (`slam.lookahead`), and the free-space consistency
of two scans (`slam.see_through`): a periodic corridor, no odometry, the robot speeds up so the constant-velocity
prediction sits on the wrong peak."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sim.types import Pose2D
from slam import se2
from slam.csm import MatchGrid, search
from slam.hypotheses import WideSearch
from slam.lookahead import LookaheadConfig, alternatives, choose, surface_peaks
from slam.match_covariance import translation_surface
from slam.see_through import inconsistency, seen_through
from tests.slam import synth

WIDE = WideSearch(2.5, math.radians(85), 0.25, 0.01, 0.01)  # the default wide window and motion prior


def _corridor() -> np.ndarray:
    """A 2 m wide corridor from x = 0 to 25 whose walls are 0.6 m panels every 1 m (doors between), closed at
    both ends: away from its ends every 1 m shift along it looks the same."""
    segs = [(0.0, -1.0, 0.0, 1.0), (25.0, -1.0, 25.0, 1.0)]
    for x0 in np.arange(0.0, 25.0, 1.0):
        segs += [(x0, 1.0, x0 + 0.6, 1.0), (x0, -1.0, x0 + 0.6, -1.0)]
    return np.array(segs)


def _points(x: float, max_range: float) -> np.ndarray:
    return synth.raycast(_corridor(), Pose2D(x, 0.0, 0.0), beams=360, max_range=max_range).points()


def _map() -> np.ndarray:
    """The corridor's walls sampled every 2 cm (as a well-mapped local map)."""
    out = []
    for x0, y0, x1, y1 in _corridor():
        t = np.linspace(0.0, 1.0, max(2, math.ceil(math.hypot(x1 - x0, y1 - y0) / 0.02) + 1))
        out.append(np.column_stack([x0 + t * (x1 - x0), y0 + t * (y1 - y0)]))
    return np.vstack(out)


def test_surface_peaks() -> None:
    offs = np.array([[0.0, 0.0], [0.15, 0.0], [1.0, 0.0], [1.15, 0.0], [-2.0, 0.0], [0.0, 3.0]])
    scores = np.array([0.9, 0.88, 0.86, 0.87, 0.80, 0.70])
    # the best, its neighbour (too close), then the best of the 1 m peak, then −2 m; 3 m is beyond the margin
    got = surface_peaks(offs, scores, margin=0.12, separation=0.5, limit=4)
    assert [tuple(p) for p in got] == [(1.15, 0.0), (-2.0, 0.0)]
    assert [tuple(p) for p in surface_peaks(offs, scores, margin=0.05, separation=0.5, limit=4)] == [(1.15, 0.0)]
    assert len(surface_peaks(offs, scores, margin=0.5, separation=0.5, limit=1)) == 1


def test_seen_through_closed_form() -> None:
    # scan a at the origin sees a wall at x = 5 (|y| ≤ 2); b's returns on a wall at x = 3 are in a's free space
    ys = np.linspace(-2.0, 2.0, 41)
    wall5 = np.column_stack([np.full(41, 5.0), ys])
    wall3 = np.column_stack([np.full(41, 3.0), ys * 0.5])  # within a's field of view, every bearing covered
    assert seen_through((0.0, 0.0, 0.0), wall5, (0.0, 0.0, 0.0), wall3) == (41, 41)
    assert seen_through((0.0, 0.0, 0.0), wall5, (0.0, 0.0, 0.0), wall5) == (0, 41)
    # b 2 m further on sees the same wall 2 m closer: consistent, both ways
    b = wall5 - np.array([2.0, 0.0])
    assert seen_through((0.0, 0.0, 0.0), wall5, (2.0, 0.0, 0.0), b)[0] == 0
    assert inconsistency((2.0, 0.0, 0.0), b, [((0.0, 0.0, 0.0), wall5)]) == 0.0
    # a wall at x = 3 on a's bearings, placed at the origin: all of it lies in a's free space, while a's wall
    # is behind it (occluded, not seen through): 41 of the 82 returns that see each other
    on_bearings = np.column_stack([np.full(41, 3.0), ys * 0.6])
    assert inconsistency((0.0, 0.0, 0.0), on_bearings, [((0.0, 0.0, 0.0), wall5)]) == pytest.approx(0.5)


def test_lookahead_takes_the_true_corridor_peak() -> None:
    # the corridor is mapped (both ends too) and the robot came in 1 m steps to x = 5; it then moves 2 m to
    # x = 7, where its view is short (3 m: panels only), then on to 9 and 11 (full range: the ends are seen)
    base = _map()
    grid = MatchGrid(base, 0.05, 0.07, margin=6.5)
    prev, guess = (5.0, 0.0, 0.0), (6.0, 0.0, 0.0)  # constant velocity: 1 m on
    pts = _points(7.0, 3.0)
    wp = pts[np.linspace(0, len(pts) - 1, 80).astype(int)]
    best = WIDE.run(grid, wp, guess)
    assert best is not None and abs(best.pose[0] - 6.0) < 0.05  # the wide search takes the prediction's peak
    cfg = LookaheadConfig()
    surface = translation_surface(grid, wp, best.pose, 2.5, 0.15)
    alts = alternatives(grid, wp, best, guess, surface, cfg, (0.01, 0.01))
    assert any(abs(a.pose[0] - 7.0) < 0.05 for a in alts)  # the true peak is a hypothesis

    def grid_of(chain: list[tuple[se2.PoseTuple, np.ndarray]]) -> MatchGrid:
        return MatchGrid(np.vstack([base, *[se2.transform_points(p, q) for p, q in chain]]), 0.05, 0.07,
                         margin=6.5)

    following = [(_points(x, 30.0)[::4], _points(x, 30.0)) for x in (9.0, 11.0)]
    chosen, totals = choose([best, *alts], prev, pts, following, grid_of, WIDE.run)
    assert abs(chosen.pose[0] - 7.0) < 0.05 and abs(chosen.pose[1]) < 0.05, (chosen, totals)
    # without the following scans the wrong peak stays (the decision needs them)
    assert choose([best, *alts], prev, pts, [], grid_of, WIDE.run)[0] is best


def test_refined_alternative_is_a_real_peak() -> None:
    grid = MatchGrid(_map(), 0.05, 0.07, margin=6.5)
    pts = _points(7.0, 3.0)
    r = search(grid, pts, (7.1, 0.05, 0.02), window_xy=0.2, window_yaw=math.radians(5))
    assert r is not None and abs(r.pose[0] - 7.0) < 0.05 and abs(r.pose[1]) < 0.05 and abs(r.pose[2]) < 0.02
