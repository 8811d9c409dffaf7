"""Lookups on planning.grid.OccupancyGrid that SLAM needs (the grid type and map files are planning's)."""

from __future__ import annotations

import numpy as np
from scipy.ndimage import convolve

from planning.grid import UNKNOWN_CELL, OccupancyGrid


def values_at(grid: OccupancyGrid, xy: np.ndarray, outside: int = UNKNOWN_CELL) -> np.ndarray:
    """Cell values at (n, 2) map-frame points; points off the grid get `outside`."""
    rows, cols = grid.world_to_cells(xy)
    ok = grid.in_bounds_many(rows, cols)
    out = np.full(len(rows), outside, dtype=np.int8)
    out[ok] = grid.data[rows[ok], cols[ok]]
    return out


def occupied_points(grid: OccupancyGrid, threshold: int = 65) -> np.ndarray:
    """Centres of occupied cells (n, 2): the point set scan-to-map matching aligns to."""
    rows, cols = np.nonzero(grid.occupied(threshold))
    return grid.cells_to_world(rows, cols)


def surface_points(grid: OccupancyGrid, threshold: int = 65) -> np.ndarray:
    """Occupied cells as surface points: each cell centre moved to the centroid of the occupied cells in
    its 3×3 neighbourhood. A wall two cells thick (a surface on a cell boundary marks both sides)
    becomes one line on the boundary, so point-to-line ICP has one minimum there instead of one per
    layer, ±half a cell off."""
    occ = grid.occupied(threshold)
    rows, cols = np.nonzero(occ)
    if rows.size == 0:
        return np.zeros((0, 2))
    k = np.ones((3, 3))
    w = convolve(occ.astype(np.float64), k, mode="constant")
    mc = convolve(occ * np.arange(grid.width)[None, :].astype(np.float64), k, mode="constant")
    mr = convolve(occ * np.arange(grid.height)[:, None].astype(np.float64), k, mode="constant")
    return grid.cells_to_world(mr[rows, cols] / w[rows, cols], mc[rows, cols] / w[rows, cols])
