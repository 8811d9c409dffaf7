"""slam/csm.py MatchGrid: the stamped field is the closed form max over the points of exp(−d²/2σ²) (cell
distances, cut at 4σ), whether the kernel is stamped in place (a margin it cannot leave) or on a padded copy
(points at the grid's edge); every level is the max over its block of level 0."""

from __future__ import annotations

import math

import numpy as np
import pytest

from slam.csm import MatchGrid


def _closed_form(grid: MatchGrid, pts: np.ndarray, sigma: float) -> np.ndarray:
    res = grid.resolution
    h, w = grid.field.shape
    cells = np.unique(np.floor((pts - grid.origin) / res).astype(np.int64), axis=0)
    rows, cols = np.mgrid[0:h, 0:w]
    out = np.zeros((h, w))
    for cx, cy in cells:
        d2 = ((cols - cx) ** 2 + (rows - cy) ** 2) * res ** 2
        out = np.maximum(out, np.where(d2 <= (4 * sigma) ** 2, np.exp(-0.5 * d2 / sigma ** 2), 0.0))
    out[0, :] = out[-1, :] = 0.0
    out[:, 0] = out[:, -1] = 0.0
    return out


@pytest.mark.parametrize("margin", [0.0, 0.12, 1.0])  # kernel off the grid, partly, never
def test_field_is_the_closed_form_max_of_kernels(margin: float) -> None:
    rng = np.random.default_rng(3)
    pts = rng.uniform(0.0, 2.0, size=(60, 2))
    sigma = 0.07
    grid = MatchGrid(pts, 0.05, sigma, margin=margin)
    assert np.allclose(grid.field, _closed_form(grid, pts, sigma), atol=1e-6)


def test_levels_are_block_maxima() -> None:
    rng = np.random.default_rng(4)
    grid = MatchGrid(rng.uniform(0.0, 1.5, size=(40, 2)), 0.05, 0.07, margin=0.3)
    f = grid.field
    h, w = f.shape
    for lv in range(1, 4):
        b = 1 << lv
        ref = np.array([[f[r:r + b, c:c + b].max() for c in range(w)] for r in range(h)])
        ref[0, :] = ref[-1, :] = 0.0
        ref[:, 0] = ref[:, -1] = 0.0
        assert np.array_equal(grid.level(lv), ref), lv
    assert math.isclose(float(grid.field.max()), 1.0)
