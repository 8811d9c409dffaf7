"""slam/csm.py: the branch-and-bound search returns the brute-force optimum of the same lattice, and the
fast lookup (unsigned clamp onto the zero border) equals two-sided clipping, off-grid points included."""

from __future__ import annotations

import math

import numpy as np

from slam import se2
from slam.csm import MatchGrid, _lookup, first_per_cell, search


def _room(rng: np.random.Generator) -> np.ndarray:
    t = np.linspace(0.0, 1.0, 200)[:, None]
    walls = [np.array([0.0, 0.0]) + t * np.array([8.0, 0.0]), np.array([8.0, 0.0]) + t * np.array([0.0, 5.0]),
             np.array([8.0, 5.0]) + t * np.array([-8.0, 0.0]), np.array([0.0, 5.0]) + t * np.array([0.0, -5.0]),
             np.array([3.0, 1.0]) + t * np.array([1.0, 1.5])]
    clutter = rng.uniform([0.5, 0.5], [7.5, 4.5], size=(30, 2))
    return np.vstack([*walls, clutter])


def _brute(grid: MatchGrid, pts: np.ndarray, guess: tuple[float, float, float], window_xy: float,
           window_yaw: float, w_xy: float, w_yaw: float) -> float:
    """Best penalised score over the exact lattice `search` uses (same angle step and cell offsets)."""
    res = grid.resolution
    rmax = min(10.0, float(np.hypot(pts[:, 0], pts[:, 1]).max()))
    step = math.acos(max(-1.0, 1.0 - res * res / (2.0 * max(rmax, res) ** 2)))
    na, nw = math.ceil(window_yaw / step), math.ceil(window_xy / res)
    best = -math.inf
    for a in guess[2] + step * np.arange(-na, na + 1):
        for ix in range(-nw, nw + 1):
            for iy in range(-nw, nw + 1):
                pose = (guess[0] + ix * res, guess[1] + iy * res, float(a))
                s = grid.score(pose, pts) - w_xy * ((ix * res) ** 2 + (iy * res) ** 2) - w_yaw * (a - guess[2]) ** 2
                best = max(best, s)
    return best


def test_branch_and_bound_finds_the_brute_force_optimum() -> None:
    rng = np.random.default_rng(3)
    world = _room(rng)
    truth = (4.1, 2.3, 0.05)
    scan = se2.transform_points(_inv(truth), world[::4])
    scan = np.vstack([scan, [[20.0, 0.0], [-15.0, 3.0], [4.0, 4.3]]])  # off the grid, and in its margin
    guess = (4.25, 2.2, 0.0)
    # margin 0.5 m: per-axis clamped lookups; 3 m: the zero margin holds the window, flat lookups
    for margin in (0.5, 3.0):
        grid = MatchGrid(world, 0.05, 0.07, margin=margin)
        assert (grid.zero_margin - 16 + 1 >= 13) == (margin > 1)  # window ±0.3 m: 13 cells, top block 16
        for w_xy, w_yaw in ((0.0, 0.0), (0.5, 0.5)):
            res = search(grid, scan, guess, window_xy=0.3, window_yaw=0.06, prior_weight_xy=w_xy,
                         prior_weight_yaw=w_yaw)
            assert res is not None
            assert math.isclose(res.score, _brute(grid, scan, guess, 0.3, 0.06, w_xy, w_yaw), abs_tol=1e-6)
        res = search(grid, scan, guess, window_xy=0.3, window_yaw=0.06)
        assert res is not None and math.hypot(res.pose[0] - truth[0], res.pose[1] - truth[1]) <= 0.05


def _inv(p: tuple[float, float, float]) -> tuple[float, float, float]:
    c, s = math.cos(p[2]), math.sin(p[2])
    return (-c * p[0] - s * p[1], s * p[0] - c * p[1], -p[2])


def test_fast_lookup_equals_clipping_with_a_zero_border() -> None:
    rng = np.random.default_rng(0)
    grid = rng.random((40, 60)).astype(np.float32)
    grid[0, :] = grid[-1, :] = 0.0
    grid[:, 0] = grid[:, -1] = 0.0
    for dtype in (np.int32, np.int64):
        cols = rng.integers(-100, 160, size=(7, 50)).astype(dtype)
        rows = rng.integers(-100, 140, size=(7, 50)).astype(dtype)
        ref = grid[np.clip(rows, 0, 39), np.clip(cols, 0, 59)]
        np.testing.assert_array_equal(_lookup(grid, cols, rows), ref)


def test_first_per_cell_matches_row_wise_unique() -> None:
    cells = np.random.default_rng(1).integers(-5, 5, size=(500, 2))
    _, first = np.unique(cells, axis=0, return_index=True)
    np.testing.assert_array_equal(first_per_cell(cells), np.sort(first))
