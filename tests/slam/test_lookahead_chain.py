"""The look-ahead's free-space term read over a hypothesis' whole chain (`slam.lookahead.free_space_penalty`),
and the free-space share counted against all returns (`slam.see_through`).

A periodic corridor without odometry: the hypothesis scan sees only the panels near it, so the true pose and a
pose one period back score the same and neither contradicts what the older scans saw. The next scans see the
end wall. From the wrong hypothesis they are matched (self-consistently) one period back too, which puts the
end wall where the older scans saw through; the old rule (the hypothesis' own scan only) cannot see that.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from sim.types import Pose2D
from slam import se2
from slam.csm import CsmResult, MatchGrid
from slam.hypotheses import HypothesesConfig, WideSearch, alternative
from slam.lookahead import LookaheadConfig, choose, free_space_penalty
from slam.see_through import inconsistency, seen_through
from tests.slam import synth

WIDE = WideSearch(2.5, math.radians(85), 0.25, 0.01, 0.01)


def _corridor() -> np.ndarray:
    """2 m wide, x = 0 … 20, walls of 0.6 m panels every 1 m, an end wall at x = 20 (the start is open)."""
    segs = [(20.0, -1.0, 20.0, 1.0)]
    for x0 in np.arange(0.0, 20.0, 1.0):
        segs += [(x0, 1.0, x0 + 0.6, 1.0), (x0, -1.0, x0 + 0.6, -1.0)]
    return np.array(segs)


def _points(x: float, max_range: float) -> np.ndarray:
    return synth.raycast(_corridor(), Pose2D(x, 0.0, 0.0), beams=360, max_range=max_range).points()


def _panels(x0: float, x1: float) -> np.ndarray:
    """The panels between x0 and x1 sampled every 2 cm (the local map the scores read: no end wall)."""
    out = []
    for x in np.arange(0.0, 20.0, 1.0):
        if x0 <= x <= x1:
            t = np.linspace(x, x + 0.6, 31)
            out += [np.column_stack([t, np.full(31, 1.0)]), np.column_stack([t, np.full(31, -1.0)])]
    return np.vstack(out)


def test_chain_free_space_picks_the_true_corridor_peak() -> None:
    # older scans at x = 2 … 5 saw down the corridor to the end wall (their free space reaches x = 20)
    others = [((x, 0.0, 0.0), _points(x, 30.0)) for x in (2.0, 3.0, 4.0, 5.0)]
    base = _panels(0.0, 19.0)

    def grid_of(chain: list[tuple[se2.PoseTuple, np.ndarray]]) -> MatchGrid:
        return MatchGrid(np.vstack([base, *[se2.transform_points(p, q) for p, q in chain]]), 0.05, 0.07,
                         margin=6.5)

    pts = _points(7.0, 2.5)  # the robot moved 5 → 7; its scan sees panels only
    wrong, truth = CsmResult((6.0, 0.0, 0.0), 0.80, 0), CsmResult((7.0, 0.0, 0.0), 0.79, 0)
    # the hypothesis scans alone do not contradict the older scans at either pose
    assert inconsistency(wrong.pose, pts, others, of_all=True) == inconsistency(truth.pose, pts, others,
                                                                                of_all=True)
    following = [(_points(x, 30.0)[::3], _points(x, 30.0)) for x in (8.0, 9.0)]
    old = free_space_penalty(others, LookaheadConfig(free_space_weight=1.0, free_space_chain=False,
                                                     free_space_of_all=False))
    chosen, totals = choose([wrong, truth], (5.0, 0.0, 0.0), pts, following, grid_of, WIDE.run, old)
    assert chosen is wrong, totals  # the old rule: self-consistent chains tie, the own score decides
    chosen, totals = choose([wrong, truth], (5.0, 0.0, 0.0), pts, following, grid_of, WIDE.run,
                            free_space_penalty(others, LookaheadConfig()))
    assert chosen is truth, totals
    # and it is the chain that decides: the same weight and share on the hypothesis scan alone does not
    own_only = free_space_penalty(others, LookaheadConfig(free_space_chain=False))
    assert choose([wrong, truth], (5.0, 0.0, 0.0), pts, following, grid_of, WIDE.run, own_only)[0] is wrong


def test_free_space_share_of_all_returns() -> None:
    # a sees a wall at x = 5 over |y| ≤ 2; b's 41 returns on a wall at x = 3: only those within a's field of
    # view overlap, and every one of them lies in a's free space
    ys = np.linspace(-2.0, 2.0, 41)
    wall5 = np.column_stack([np.full(41, 5.0), ys])
    narrow = np.column_stack([np.full(41, 3.0), np.linspace(-6.0, 6.0, 41)])  # 9 of 41 in a's view (|y| ≤ 1.2)
    bad, seen = seen_through((0.0, 0.0, 0.0), wall5, (0.0, 0.0, 0.0), narrow)
    assert bad == seen == 9
    a = [((0.0, 0.0, 0.0), wall5)]
    # of the overlap: b's 9 in a's free space; a's returns behind b's wall are occluded, not seen through
    assert inconsistency((0.0, 0.0, 0.0), narrow, a) == pytest.approx(9 / (9 + seen_through(
        (0.0, 0.0, 0.0), narrow, (0.0, 0.0, 0.0), wall5)[1]))
    # of all returns: the same 9 against the 82 compared, whatever the overlap
    assert inconsistency((0.0, 0.0, 0.0), narrow, a, of_all=True) == pytest.approx(9 / 82)


def test_seen_through_needs_both_bracketing_beams() -> None:
    # a's beams alternate between a near post (2 m) and the wall behind it (5 m) at a depth edge; a return of b
    # at 4 m between a 5 m beam and a 2 m beam was not seen through (the 2 m beam stopped short of it)
    ang = np.radians(np.arange(-10.0, 10.5, 1.0))
    r = np.where(ang < 0.0, 5.0, 2.0)
    a = np.column_stack([r * np.cos(ang), r * np.sin(ang)])
    b_ang = np.radians([-5.5, -0.5, 5.5])
    b = np.column_stack([4.0 * np.cos(b_ang), 4.0 * np.sin(b_ang)])
    # −5.5°: both neighbours at 5 m went past it; −0.5°: one of them stopped at 2 m; 5.5°: behind the post
    assert seen_through((0.0, 0.0, 0.0), a, (0.0, 0.0, 0.0), b) == (1, 3)


def test_weak_match_alternative_for_the_lookahead() -> None:
    # a weak wide match far from the prediction gets the half window's best match around the prediction as a
    # second hypothesis; a strong match, or an alternative at the match itself, gets none
    grid = MatchGrid(_panels(0.0, 19.0), 0.05, 0.07, margin=6.5)
    pts = _points(7.0, 2.5)
    cfg = HypothesesConfig()
    alt = alternative(grid, pts, CsmResult((5.0, 0.3, 0.4), 0.3, 0), (7.05, 0.0, 0.0), WIDE, cfg)
    assert alt is not None and math.hypot(alt.pose[0] - 7.0, alt.pose[1]) < 0.1 and abs(alt.pose[2]) < 0.05
    assert alternative(grid, pts, CsmResult((5.0, 0.3, 0.4), 0.6, 0), (7.05, 0.0, 0.0), WIDE, cfg) is None
    assert alternative(grid, pts, CsmResult(alt.pose, 0.3, 0), (7.05, 0.0, 0.0), WIDE, cfg) is None
