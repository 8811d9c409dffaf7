"""Distance to the nearest static obstacle and the direction to it, for every robot in one array lookup."""

from __future__ import annotations

import numpy as np
from scipy.ndimage import distance_transform_edt

from planning import OccupancyGrid


class StaticClearance:
    """Exact Euclidean distance transform of the static occupancy grid, with the nearest obstacle cell."""

    def __init__(self, grid: OccupancyGrid) -> None:
        self.grid = grid
        occupied = grid.occupied()
        self.any = bool(occupied.any())
        if self.any:
            _, idx = distance_transform_edt(~occupied, return_indices=True)
            ox, oy = grid.origin
            res = grid.resolution
            self._nearest = np.stack([ox + (idx[1] + 0.5) * res, oy + (idx[0] + 0.5) * res], axis=-1)

    def query(self, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(distance from each point to the nearest obstacle cell's edge (m), unit vector towards it).

        Points off the map are treated as touching an obstacle (distance 0) with no direction."""
        xy = np.asarray(xy, dtype=float).reshape(-1, 2)
        n = len(xy)
        if not self.any:
            return np.full(n, np.inf), np.zeros((n, 2))
        rows, cols = self.grid.world_to_cells(xy)
        ok = self.grid.in_bounds_many(rows, cols)
        dist, normal = np.zeros(n), np.zeros((n, 2))
        delta = self._nearest[rows[ok], cols[ok]] - xy[ok]
        d = np.hypot(delta[:, 0], delta[:, 1])
        dist[ok] = np.maximum(d - 0.5 * self.grid.resolution, 0.0)
        normal[ok] = delta / np.maximum(d, 1e-9)[:, None]
        return dist, normal
